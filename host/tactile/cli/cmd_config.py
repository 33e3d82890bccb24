"""``tactile config --port P [...]``: change rate, contact gate and streams; unset options keep
the board's current values.  ``--persist`` also stores them on the board (used at boot)."""

import argparse

from tactile.board.client import info_dict
from tactile.cli.board_args import add_port_argument, connect
from tactile.cli.cmd_info import info_lines
from tactile.errors import InputError
from tactile.output.text import printable_lines
from tactile_protocol import constants as C
from tactile_protocol.settings import (
    GATES,
    MAX_DEBOUNCE,
    MIN_RATE_HZ,
    STREAMS,
    stream_flags,
    to_counts,
    to_newtons,
)


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--rate", type=int, help="sample rate, Hz")
    parser.add_argument("--enter", type=float, help="gate enter threshold, N (thesis: 1.39 N)")
    parser.add_argument("--exit", type=float, help="gate exit threshold, N (<= --enter)")
    parser.add_argument("--debounce", type=int, help="consecutive readings to enter/leave contact")
    parser.add_argument("--gate", choices=tuple(GATES), help="gate on |F| in x-y (§5.1) or 3-D")
    parser.add_argument("--streams", help=f"comma list of: {', '.join(STREAMS)} ('' for none)")
    parser.add_argument(
        "--autostart", action=argparse.BooleanOptionalAction, help="stream from boot"
    )
    parser.add_argument("--persist", action="store_true", help="also save on the board")


def run(args):
    flags_from = _streams(args.streams)
    client = connect(args)
    try:
        cur = client.get_info()
        values = _values(args, cur, flags_from)
        _check(values, cur.max_rate_hz)
        client.configure(*values)
        info = info_dict(client.get_info())
    finally:
        client.close()
    print(printable_lines(info_lines(info)))
    return 0


def _streams(text):
    if text is None:
        return None
    names = [s.strip() for s in text.split(",") if s.strip()]
    try:
        stream_flags(names)
    except ValueError as exc:
        raise InputError(f"--streams: {exc}") from None
    return names


def _check(values, max_rate_hz):
    """Refuse, before anything is sent, a value the board would NAK: one line with its range."""
    why = problem(*values[:4], max_rate_hz)
    if why is not None:
        raise InputError(why)


def _values(args, cur, streams):
    flags = cur.flags & (C.CFG_WRITABLE & ~C.CFG_PERSIST)
    if streams is not None:
        flags = flags & ~sum(STREAMS.values()) | stream_flags(streams)
    if args.gate is not None:
        flags = flags & ~sum(GATES.values()) | GATES[args.gate]
    if args.autostart is not None:
        flags = flags | C.CFG_AUTOSTART if args.autostart else flags & ~C.CFG_AUTOSTART
    if args.persist:
        flags |= C.CFG_PERSIST
    pick = lambda new, old: old if new is None else new  # noqa: E731
    return (
        pick(args.rate, cur.rate_hz),
        pick(args.enter, to_newtons(cur.enter_threshold)),
        pick(args.exit, to_newtons(cur.exit_threshold)),
        pick(args.debounce, cur.debounce),
        flags,
    )


def problem(rate_hz, enter_N, exit_N, debounce, max_rate_hz):
    """None, or one line naming the first value out of range and the range allowed: the
    firmware's rule (``tactile_fw.settings.check``) in the units and options a user types,
    checked before any CONFIG is sent."""
    if not MIN_RATE_HZ <= rate_hz <= max_rate_hz:
        allowed = f"{MIN_RATE_HZ}..{max_rate_hz} Hz on this board"
        return f"--rate: {rate_hz} Hz is out of range: {allowed}"
    if not 0 <= to_counts(enter_N):
        return f"--enter: {enter_N:g} N is out of range: 0 N or more"
    if not 0 <= to_counts(exit_N) <= to_counts(enter_N):
        return f"--exit: {exit_N:g} N is out of range: 0..{enter_N:g} N (at most --enter)"
    if not 1 <= debounce <= MAX_DEBOUNCE:
        return f"--debounce: {debounce} is out of range: 1..{MAX_DEBOUNCE} readings"
    return None
