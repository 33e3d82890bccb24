"""Board emulator: the real firmware against a simulated F/T sensor, behind a serial port.

``load_scene(path)`` reads a TOML scene; ``EmulatedBoard(scene)`` runs the
firmware on simulated time; ``servers.serve(scene, core=...)`` serves it on a
pseudo-terminal (``with ... as server``: ``server.path``) and ``sim://SCENE``
(``tactile_sim.urlhandler``) reaches it in process through pyserial.
"""

from tactile_sim.emulator.scene import SceneError, load_scene

__all__ = ["SceneError", "load_scene"]
