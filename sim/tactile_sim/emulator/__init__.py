"""Board emulator: the real firmware against a simulated F/T sensor, behind a serial port.

``load_scene(path)`` reads a TOML scene; ``EmulatedBoard(scene)`` runs the
firmware on simulated time; ``serve_pty`` exposes it on a pseudo-terminal
and ``sim://SCENE`` (``tactile_sim.urlhandler``) reaches it through pyserial.
"""

from tactile_sim.emulator.scene import SceneError, load_scene

__all__ = ["SceneError", "load_scene"]
