"""``tactile emulate SCENE``: serve an emulated board on a pseudo-terminal until interrupted.

Prints the device path; open it with any serial program (``tactile record
--port PATH``).  ``--link PATH`` keeps a stable symlink to the current
pty, which survives the scene's simulated disconnects.  It replaces only an
emulator's own link (a symlink to a pty): a file, a directory or another
symlink at PATH is refused with one line (exit 2) and left as it was.
``--core c`` serves the C firmware core (``firmware/c``, built with the host's C
compiler on first use) instead of the MicroPython one, behind the same pty; without
``--core`` the scene's ``[board] core`` decides (default ``python``).  ``--core qemu``
runs the C core cross-compiled for a Cortex-M0 in QEMU (``-M microbit``), its UART
bridged to the pty and the scene's sensors served over semihosting
(``tactile_sim.emulator.qemu_server``); needs ``arm-none-eabi-gcc`` and
``qemu-system-arm``, and a scene without ``[link] disconnect`` windows.

The scene plays from the first host's open (``--now``: at once), and again from its start
for each later host session, as a robot started again: ``--pose-log`` is then written
again, stamped by the board's clock at the new start, before the board hears the host
(``--once``: the scene plays once, whatever hosts come and go).  ``--duration`` is the
board's time served, whether or not a host came (one that does not come is waited for a
few seconds, as any hold).

The board's id (HELLO ``board_id``, which ``record`` checks after a lost port): with
``--link``, derived from the link's path, so that an emulator restarted behind the same link
is the same board, rebooted; without, drawn at random, so that two emulators differ;
``--board-id HEX`` names it.  An emulated Pico's is its flash chip's (one per ``--flash``).
"""

import contextlib
import pathlib
import signal
import sys

from tactile.calib.ati import format_cal
from tactile.errors import InputError
from tactile.files.writing import write_bytes
from tactile.output.text import printable
from tactile.robot import parse_address
from tactile_sim.emulator import load_scene, pty_link
from tactile_sim.emulator.device import EmulatedBoard, link_board_id
from tactile_sim.emulator.ft_model import per_volt_matrix
from tactile_sim.emulator.link_faults import LinkFaults
from tactile_sim.emulator.robot_server import EmulatedArm, RobotServer, board_waiter
from tactile_sim.emulator.servers import server_for


def add_arguments(parser):
    parser.add_argument("scene", help="scene file or shipped scene name (e.g. press, ch5_convex)")
    parser.add_argument(
        "--link", help="also make this symlink point at the device (never over a file)"
    )
    parser.add_argument(
        "--fast", action="store_true", help="as fast as possible (default: real time)"
    )
    parser.add_argument(
        "--duration",
        type=float,
        metavar="S",
        help="stop after this much of the board's time, in seconds, whether or not a host "
        "came or reads (the board waits for a host that is not there, or not reading, at most"
        " a few seconds at a time)",
    )
    parser.add_argument(
        "--once",
        action="store_true",
        help="play the scene once (default: again from its start for each new host session,"
        " as a robot started again, --pose-log written again)",
    )
    parser.add_argument("--no-faults", action="store_true", help="ignore the scene's [link] faults")
    parser.add_argument(
        "--cal-file",
        metavar="FILE",
        help="write the emulated transducer's calibration here, in ATI's .cal format, as its"
        " maker ships it (for tactile calibrate ... --volts-per-count 3.07e-9)",
    )
    parser.add_argument(
        "--pose-log",
        help="write the robot's log for the scene here (for tactile record --pose-log)",
    )
    parser.add_argument(
        "--core",
        choices=("python", "c", "qemu", "rp2040"),
        help="firmware to run: the MicroPython one, the C core, the C core's Cortex-M0 image "
        "in QEMU, or an emulated Raspberry Pi Pico running what 'tactile flash' put on it "
        "(default: the scene's [board] core, else python)",
    )
    parser.add_argument(
        "--flash",
        metavar="FILE",
        help="--core rp2040: the emulated Pico's flash, kept across runs (default: "
        "$XDG_STATE_HOME/tactile/pico.flash; a new file holds stock MicroPython)",
    )
    parser.add_argument(
        "--board-id",
        metavar="HEX",
        help="the board's id in HELLO, 16 hex digits (default: one per --link, else random)",
    )
    parser.add_argument(
        "--robot",
        metavar="HOST:PORT",
        help="serve the emulated arm of a commanded scene on this TCP address (port 0: any "
        "free port; its address is printed) in the line protocol of docs/robot.md",
    )
    parser.add_argument(
        "--now",
        action="store_true",
        help="start the scene at once (default: when a host first opens the port)",
    )


def run(args):
    if args.link:
        pty_link.check(args.link)  # before the scene is built: refuse a file at once
    robot = parse_address(args.robot) if args.robot is not None else None
    scene = load_scene(args.scene)
    commanded = _check_robot(scene, robot, args.core)
    link = scene.link or {}
    disconnects = () if args.no_faults else link.get("disconnect", ())
    if args.core in ("qemu", "rp2040") and disconnects:
        raise InputError(f"{scene.path}: [link] disconnect: not served with --core {args.core} "
                         "(the chip owns its port); use --no-faults or another core")  # fmt: skip
    board = EmulatedBoard(scene, core=args.core, board_id=_board_id(args))
    if commanded:  # the arm runs on the board's clock from the start, whatever hosts do
        args.now = args.once = True

        def clock():
            return board.t_us

        arm = EmulatedArm(board.motion, clock, board_waiter(clock), args.pose_log)
    faults = None if args.no_faults else LinkFaults.from_scene(scene.link)
    if args.flash and args.core != "rp2040":
        raise InputError("--flash: only with --core rp2040 (the emulated Pico's flash file)")
    flash = {"flash": args.flash} if args.flash else {}  # (the emulated Pico's)
    if args.duration is not None and not args.duration > 0:
        raise InputError(f"--duration: {args.duration} is not a positive number of seconds")
    log = (lambda at_us: _write_log(board.motion, args.pose_log, at_us)) if args.pose_log else None
    server = server_for(board, link_path=args.link, realtime=not args.fast, faults=faults,
                        disconnects=disconnects, duration_s=args.duration,
                        when_opened=not args.now, replay=not args.once, on_scene=log,
                        **flash)  # fmt: skip
    server.prepare()  # built or powered (or refused in one line) before the port is offered
    _exit_on_sigterm()  # so that QEMU, the chip and the --link go too
    if log is not None:
        log(0)
    if args.cal_file:
        _write_cal(scene, args.cal_file)
    if commanded:
        robot = RobotServer(arm, *robot)  # (listening before its address is printed)
    path = server.open()
    print(printable(path), flush=True)
    if commanded:
        print(printable(robot.address), flush=True)
    when = "now" if args.now else "when a host opens the port"
    if args.core == "rp2040":  # a Pico powers up with its USB cable
        when = "now, running while a host has the port open" if args.fast else "now"
    again = "" if args.once else ", again for each new host"
    print(printable(f"emulating scene '{scene.name}' ({scene.path}) on the {board.core} core, "
                    f"starting {when}{again}; Ctrl-C to stop"), file=sys.stderr)  # fmt: skip
    with contextlib.ExitStack() as stack:
        if commanded:
            stack.enter_context(robot)
        with server:  # serves until its duration, the board's end or Ctrl-C; then closes
            server.wait()
    return 0


def _check_robot(scene, robot, core):
    """Whether the scene is commanded; ``--robot`` is for such a scene and it needs one."""
    kind = scene.motion["kind"]
    if robot is not None and kind != "commanded":
        raise InputError(f"--robot: only with a scene of [motion] kind = \"commanded\" "
                         f"({scene.path} has kind = \"{kind}\")")  # fmt: skip
    if robot is None and kind == "commanded":
        raise InputError(f"{scene.path}: a commanded scene moves only when told: add "
                         "--robot 127.0.0.1:PORT (0: any free port)")  # fmt: skip
    if robot is not None and core in ("qemu", "rp2040"):
        raise InputError(f"--robot: served beside the python or c core, not --core {core}")
    return robot is not None


def _board_id(args):
    """--board-id as 8 bytes; else the link's own id (not a Pico's: its flash names it)."""
    if args.board_id is not None:
        try:
            board_id = bytes.fromhex(args.board_id)
        except ValueError:
            board_id = b""
        if len(board_id) != 8:
            raise InputError(f"--board-id: {args.board_id!r} is not 16 hex digits (8 bytes)")
        return board_id
    if args.link and args.core != "rp2040":
        return link_board_id(args.link)
    return None


def _exit_on_sigterm():
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


def _write_log(motion, path, at_us):
    """The robot's log: joints or sensor poses (EP2, ch. 5) or the probe log (EP1 roll),
    stamped by the board's clock from ``at_us``, the scene's start (replaced whole)."""
    write = getattr(motion, "write_pose_log", None) or getattr(motion, "write_probe_log", None)
    if write is None:
        raise InputError(f"--pose-log: this scene's motion has no robot log ({path})")
    write(path, at_us)  # tactile.files.writing: not a file there, exit 2; a disk error, exit 5


def _write_cal(scene, path):
    """The scene's transducer calibration (sensor 0's; every sensor of a scene is alike)."""
    digits = "".join(c for c in pathlib.Path(path).stem if c.isdigit())[:6]
    serial = f"FT{digits or 1}"  # the calibration id tactile calibrate takes from it
    write_bytes(path, format_cal(per_volt_matrix(scene.sensor), serial))  # a disk error: 5
