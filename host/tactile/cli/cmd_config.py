"""``tactile config --port P [...]``: change rate, contact gate and streams; unset options keep
the board's current values.  ``--persist`` also stores them on the board (used at boot)."""

import argparse

from tactile.cli.board_args import add_port_argument, connect

STREAMS = ("samples", "contacts")


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--rate", type=int, help="sample rate, Hz")
    parser.add_argument("--enter", type=float, help="gate enter threshold, N (thesis: 1.39 N)")
    parser.add_argument("--exit", type=float, help="gate exit threshold, N (<= --enter)")
    parser.add_argument("--debounce", type=int, help="consecutive readings to enter/leave contact")
    parser.add_argument("--gate", choices=("xy", "3d"), help="gate on |F| in x-y (§5.1) or 3-D")
    parser.add_argument("--streams", help="comma list of: samples, contacts ('' for none)")
    parser.add_argument(
        "--autostart", action=argparse.BooleanOptionalAction, help="stream from boot"
    )
    parser.add_argument("--persist", action="store_true", help="also save on the board")


def run(args):
    from tactile.board_client import info_dict
    from tactile.cli.cmd_info import format_info

    flags_from = _streams(args.streams)
    client = connect(args)
    try:
        cur = client.get_info()
        client.configure(*_values(args, cur, flags_from))
        info = info_dict(client.get_info())
    finally:
        client.close()
    print(format_info(info))
    return 0


def _streams(text):
    from tactile.errors import InputError

    if text is None:
        return None
    names = [s.strip() for s in text.split(",") if s.strip()]
    bad = [n for n in names if n not in STREAMS]
    if bad:
        raise InputError(f"--streams: unknown stream {bad[0]!r} (samples, contacts)")
    return names


def _values(args, cur, streams):
    from tactile_protocol import constants as C

    flags = cur.flags & (C.CFG_WRITABLE & ~C.CFG_PERSIST)
    if streams is not None:
        flags &= ~(C.CFG_STREAM_SAMPLES | C.CFG_STREAM_CONTACTS)
        flags |= C.CFG_STREAM_SAMPLES if "samples" in streams else 0
        flags |= C.CFG_STREAM_CONTACTS if "contacts" in streams else 0
    if args.gate is not None:
        flags = flags | C.CFG_GATE_3D if args.gate == "3d" else flags & ~C.CFG_GATE_3D
    if args.autostart is not None:
        flags = flags | C.CFG_AUTOSTART if args.autostart else flags & ~C.CFG_AUTOSTART
    if args.persist:
        flags |= C.CFG_PERSIST
    pick = lambda new, old: old if new is None else new  # noqa: E731
    return (
        pick(args.rate, cur.rate_hz),
        pick(args.enter, cur.enter_threshold * C.FORCE_LSB_N),
        pick(args.exit, cur.exit_threshold * C.FORCE_LSB_N),
        pick(args.debounce, cur.debounce),
        flags,
    )
