"""``tactile flash --port PORT``: copy the firmware onto a MicroPython board, reset it and
check that the firmware answers (``tactile.board.flashing``).  Exit 4 with one line when the port
holds no MicroPython REPL, a step on the board fails, or the firmware does not answer."""

import sys

from tactile.board import flashing, handover
from tactile.board.flashing import WAIT_S
from tactile.cli.board_args import add_port_argument, port_of
from tactile.commands import add_quiet
from tactile.output.text import printable


def add_arguments(parser):
    add_port_argument(
        parser,
        wait=WAIT_S,
        wait_help="seconds to wait for the firmware to answer after the reset",
        port_help="the board's serial port, or mpremote's a0 (/dev/ttyACM0), u0, c0",
    )
    parser.add_argument("--dry-run", action="store_true", help="list what would be done")
    kind = parser.add_mutually_exclusive_group()
    kind.add_argument(
        "--mpy",
        action="store_true",
        default=None,
        help="require .mpy precompiled by mpy-cross (error if it does not fit the board); "
        "default: .mpy where it fits, else .py",
    )
    kind.add_argument("--no-mpy", dest="mpy", action="store_false", help="copy .py sources")
    parser.add_argument("--sensors", type=int, default=1, help="F/T sensors wired (1-4)")
    parser.add_argument("--wdt-ms", type=int, default=0, help="watchdog timeout (0: off)")
    add_quiet(parser)


def run(args):
    port = port_of(args)
    if args.dry_run:
        for line in flashing.plan(port, args.mpy, args.sensors, args.wdt_ms):
            print(printable(line))
        return 0
    bar = _Bar(args.quiet)
    try:
        done = flashing.flash(
            port, args.mpy, args.sensors, args.wdt_ms, args.wait, progress=bar, note=_note
        )
    finally:
        bar.close()
    kind = f".mpy v{done.mpy.tag}" if done.mpy else ".py sources"
    stale = f" ({len(done.removed)} stale removed)" if done.removed else ""
    print(
        printable(
            f"flashed {len(done.written)} files as {kind} to {done.port}{stale} and reset it;"
            f" it answers: {handover.describe(done.info)}"
        )
    )
    return 0


def _note(line):
    print(printable(f"tactile flash: note: {line}"), file=sys.stderr)


class _Bar:
    """A tqdm bar of the bytes copied on a terminal (stderr); nothing otherwise or quiet."""

    def __init__(self, quiet=False):
        self.bar = None
        self.quiet = quiet or not sys.stderr.isatty()

    def __call__(self, done, total):
        if self.quiet:
            return
        if self.bar is None:
            try:
                from tqdm import tqdm
            except ImportError:
                self.quiet = True
                return
            self.bar = tqdm(total=total, unit="B", unit_scale=True, desc="flash", file=sys.stderr)
        self.bar.update(done - self.bar.n)

    def close(self):
        if self.bar is not None:
            self.bar.close()
