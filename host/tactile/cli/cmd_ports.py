"""``tactile ports``: the serial ports the OS knows, with their descriptions."""

import sys

from tactile.board.serial_port import list_ports
from tactile.output.text import dumps, printable


def add_arguments(parser):
    parser.add_argument("--json", action="store_true", help="JSON lines")


def run(args):
    rows = list_ports()
    if not rows:
        print(
            "no serial ports found (plug the board in; on Linux it shows as /dev/ttyACM0; "
            "'tactile emulate press' serves an emulated one)",
            file=sys.stderr,
        )
        return 1
    if not args.json:
        print(printable(f"{'device':<20} {'description':<32} hardware id"))
    for device, description, hwid in rows:
        usb = "VID:PID" in (hwid or "")
        if args.json:
            rec = {"device": device, "description": description, "hwid": hwid, "usb": usb}
            print(dumps(rec))
        else:
            note = "" if usb else "  (no USB id: unlikely to be a board)"
            print(printable(f"{device:<20} {description:<32} {hwid}{note}"))  # a device's words
    return 0
