"""``tactile info --port P``: the board's INFO (firmware, protocol, sensors, configuration)."""

from tactile.board.client import info_dict
from tactile.cli.board_args import add_port_argument, connect
from tactile.output.text import dumps, printable_lines


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--json", action="store_true", help="one JSON object")


def run(args):
    client = connect(args)
    try:
        info = info_dict(client.get_info())
    finally:
        client.close()
    if args.json:
        print(dumps(info))
    else:
        print(printable_lines(info_lines(info)))
    return 0


def info_lines(d):
    """The INFO as lines of text, to print through ``tactile.output.text.printable_lines``
    (the device's own string is escaped there)."""
    return [
        f"firmware      {d['fw_major']}.{d['fw_minor']}.{d['fw_patch']}"
        f"  (protocol {d['protocol_version']})",
        f"board id      {d['board_id']}  (boot id 0x{d['boot_id']:08x})",
        f"sensor        {d['sensor_model']} x {d['n_sensors']}, "
        f"calibration ids {d['cal_ids']} (checksums "
        f"{', '.join(f'0x{c:04x}' for c in d['cal_crcs'])})",
        f"rate          {d['rate_hz']} Hz (ceiling {d['max_rate_hz']} Hz)",
        f"gate          {d['gate']}: enter {d['enter_threshold_N']:.4g} N, "
        f"exit {d['exit_threshold_N']:.4g} N, debounce {d['debounce']}",
        f"streams       {', '.join(d['streams']) or 'none'}"
        f"{' (autostart)' if d['autostart'] else ''}; "
        f"{'streaming' if d['streaming'] else 'stopped'}",
    ]
