"""``tactile flash --port PORT [--dry-run]``: copy the firmware onto a MicroPython board."""


def add_arguments(parser):
    parser.add_argument("--port", required=True, help="serial port or mpremote shortcut (a0, u0)")
    parser.add_argument("--dry-run", action="store_true", help="list what would be copied")
    parser.add_argument("--mpy", action="store_true", help="precompile with mpy-cross")
    parser.add_argument("--sensors", type=int, default=1, help="F/T sensors wired (1-4)")
    parser.add_argument("--wdt-ms", type=int, default=0, help="watchdog timeout (0: off)")


def run(args):
    from tactile import flashing

    if args.dry_run:
        for line in flashing.plan(args.port, args.mpy, args.sensors, args.wdt_ms):
            print(line)
        return 0
    written = flashing.flash(args.port, args.mpy, args.sensors, args.wdt_ms)
    print(f"flashed {len(written)} files to {args.port}; the board is resetting")
    return 0
