"""Each core's server, by name, and ``serve``: the one way to start an emulator on a pty.

``SERVERS`` maps a core (``cores.SERVED``) to its ``Server`` (``server``): the in-process
cores to ``PtyServer``, ``qemu`` to ``QemuServer``, ``rp2040`` (the emulated Pico) to
``PicoServer``.  ``server_for(board, **options)`` makes the one for an ``EmulatedBoard``;
``serve(scene, core=..., **options)`` builds the board too.  Either is a context manager
that serves in a thread until the block ends::

    with serve("press", realtime=False, duration_s=2.0) as server:
        port = serial.Serial(server.path)
"""

from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pico_server import PicoServer
from tactile_sim.emulator.pty_server import PtyServer
from tactile_sim.emulator.qemu_server import QemuServer
from tactile_sim.emulator.scene import Scene, load_scene

SERVERS = {"python": PtyServer, "c": PtyServer, "qemu": QemuServer, "rp2040": PicoServer}


def server_for(board, **options):
    """The server of ``board``'s core (``options``: as that server takes them)."""
    return SERVERS[board.core](board, **options)


def serve(scene, core=None, boot_id=None, **options):
    """The server of an ``EmulatedBoard`` of ``scene`` (a ``Scene``, a shipped name or a
    path) on ``core`` (None: the scene's); enter it to serve."""
    loaded = scene if isinstance(scene, Scene) else load_scene(scene)
    return server_for(EmulatedBoard(loaded, core=core, boot_id=boot_id), **options)
