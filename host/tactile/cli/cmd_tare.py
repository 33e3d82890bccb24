"""``tactile tare --port P``: bias the F/T sensor(s); returns once the board has the bias.

The board refuses a loaded sensor (exit 4, one line naming it).  ``--force`` tares anyway,
by raising the contact gate for the TARE (``BoardClient.tare``): for a sensor whose own
offset, before its first TARE since power-up, is above the gate.
"""

from tactile.cli.board_args import add_port_argument, connect
from tactile.errors import InputError
from tactile.output.text import printable
from tactile_protocol import constants as C


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--sensor", default="all", help="sensor index 0..3, or 'all'")
    parser.add_argument("--samples", type=int, default=64, help="readings averaged (default 64)")
    parser.add_argument(
        "--force",
        action="store_true",
        help="tare even above the contact gate (a sensor whose own offset exceeds it)",
    )


def run(args):
    sensor = _sensor(args.sensor, InputError)
    if not 0 < args.samples < 65536:
        raise InputError(f"--samples: {args.samples} is not in 1..65535")
    client = connect(args)
    try:
        client.tare(C.SENSOR_ALL if sensor is None else sensor, args.samples, force=args.force)
    finally:
        client.close()
    which = "all sensors" if sensor is None else f"sensor {sensor}"
    print(printable(f"tared {which} ({args.samples} readings)"))
    return 0


def _sensor(text, error):
    if text == "all":
        return None
    if text.isdigit() and int(text) < 4:
        return int(text)
    raise error(f"--sensor: {text!r} is not 0..3 or 'all'")
