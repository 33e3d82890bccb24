"""``tactile emulate SCENE``: serve an emulated board on a pseudo-terminal until interrupted.

Prints the device path; open it with any serial program (``tactile record
--port PATH``).  ``--link PATH`` keeps a stable symlink to the current
pty, which survives the scene's simulated disconnects.
"""

import sys


def add_arguments(parser):
    parser.add_argument("scene", help="scene file or shipped scene name (e.g. press, ch5_convex)")
    parser.add_argument("--link", help="also make this symlink point at the device")
    parser.add_argument(
        "--fast", action="store_true", help="as fast as possible (default: real time)"
    )
    parser.add_argument("--duration", type=float, help="stop after this many simulated seconds")
    parser.add_argument("--no-faults", action="store_true", help="ignore the scene's [link] faults")


def run(args):
    from tactile_sim.emulator import load_scene
    from tactile_sim.emulator.device import EmulatedBoard
    from tactile_sim.emulator.link_faults import LinkFaults
    from tactile_sim.emulator.pty_server import PtyServer

    scene = load_scene(args.scene)
    board = EmulatedBoard(scene)
    link = scene.link or {}
    faults = None if args.no_faults else LinkFaults.from_scene(scene.link)
    server = PtyServer(
        board,
        link_path=args.link,
        realtime=not args.fast,
        faults=faults,
        disconnects=() if args.no_faults else link.get("disconnect", ()),
    )
    path = server.open()
    print(path, flush=True)
    print(f"emulating scene '{scene.name}' ({scene.path}); Ctrl-C to stop", file=sys.stderr)
    try:
        server.serve(args.duration)
    finally:
        server.close()
    return 0
