"""``tactile ports``: the serial ports the OS knows, with their descriptions."""


def add_arguments(parser):
    parser.add_argument("--json", action="store_true", help="JSON lines")


def run(args):
    import sys

    from tactile.jsonout import dumps
    from tactile.serial_port import list_ports

    rows = list_ports()
    if not rows:
        print(
            "no serial ports found (plug the board in; on Linux it shows as /dev/ttyACM0; "
            "'tactile emulate press' serves an emulated one)",
            file=sys.stderr,
        )
        return 1
    for device, description, hwid in rows:
        if args.json:
            print(dumps({"device": device, "description": description, "hwid": hwid}))
        else:
            print(f"{device:<20} {description}  [{hwid}]")
    return 0
