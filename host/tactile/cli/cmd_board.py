"""The commands that talk to a board or read its bytes, each a ``Verb``; none loads NumPy.

``tactile info --port P``: the board's INFO (firmware, protocol, sensors, configuration).

``tactile ports``: the serial ports the OS knows, with their descriptions.

``tactile config --port P [...]``: change rate, contact gate and streams; unset options keep
the board's current values.  ``--persist`` also stores them on the board (used at boot).

``tactile tare --port P``: bias the F/T sensor(s); returns once the board has the bias.

The board refuses a loaded sensor (exit 4, one line naming it).  ``--force`` tares anyway,
by raising the contact gate for the TARE (``BoardClient.tare``): for a sensor whose own
offset, before its first TARE since power-up, is above the gate.

``tactile flash --port PORT``: copy the firmware onto a MicroPython board, reset it and
check that the firmware answers (``tactile.board.flashing``).  Exit 4 with one line when the port
holds no MicroPython REPL, a step on the board fails, or the firmware does not answer.

``tactile decode CAPTURE.bin [--json]``: raw byte capture -> one message per line.

Damaged input is not an error: it is skipped, counted, and the counters
close the output (exit 0).  A frame whose content breaks the protocol's
limits prints as INVALID, naming the message and the field, and is counted
(``invalid``).  Only an unreadable file is an error (exit 2).  Text and JSON
follow one rule (``tactile.output.text``): device strings are escaped and a
non-finite number is ``null`` in both.
"""

import argparse
import sys

from tactile.board import flashing, handover
from tactile.board.client import info_dict
from tactile.board.flashing import WAIT_S
from tactile.board.serial_port import list_ports
from tactile.board.stream_decoder import StreamDecoder
from tactile.cli.options import add_port_argument, connect, port_of
from tactile.commands import Verb, add_quiet
from tactile.errors import InputError
from tactile.output.text import dumps, fields, printable, printable_lines
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


def add_info_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--json", action="store_true", help="one JSON object")


def run_info(args):
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


INFO = Verb(add_info_arguments, run_info)


def add_ports_arguments(parser):
    parser.add_argument("--json", action="store_true", help="JSON lines")


def run_ports(args):
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


PORTS = Verb(add_ports_arguments, run_ports)


def add_config_arguments(parser):
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


def run_config(args):
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


CONFIG = Verb(add_config_arguments, run_config)


def add_tare_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--sensor", default="all", help="sensor index 0..3, or 'all'")
    parser.add_argument("--samples", type=int, default=64, help="readings averaged (default 64)")
    parser.add_argument(
        "--force",
        action="store_true",
        help="tare even above the contact gate (a sensor whose own offset exceeds it)",
    )


def run_tare(args):
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


TARE = Verb(add_tare_arguments, run_tare)


def add_flash_arguments(parser):
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


def run_flash(args):
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


FLASH = Verb(add_flash_arguments, run_flash)


CHUNK = 1 << 16


def add_decode_arguments(parser):
    parser.add_argument("capture", help="raw bytes as read from the serial port")
    parser.add_argument("--json", action="store_true", help="JSON lines (default: readable text)")


def run_decode(args):
    decoder = StreamDecoder(older=True)  # a capture of any version this host reads
    write = sys.stdout.write
    fmt = dumps if args.json else _text
    try:
        handle = open(args.capture, "rb")
    except OSError as exc:
        raise InputError(f"{args.capture}: cannot read: {exc.strerror}") from None
    with handle:
        while chunk := handle.read(CHUNK):
            for msg in decoder.feed(chunk):
                write(fmt(msg.to_dict()) + "\n")
    summary = decoder.counters.as_dict()
    summary["pending_bytes"] = decoder.pending_bytes
    write((dumps({"summary": summary}) if args.json else _text_summary(summary)) + "\n")
    return 0


def _text(d):
    if d["type"] == "INVALID":
        head = f"{d['message']} seq={d['seq']} timestamp_us={d['timestamp_us']}"
        return f"INVALID  {head}: {printable(d['error'])}"
    return f"{d['type']:<8} {fields(d)}"


def _text_summary(s):
    return "summary  " + fields(s, skip=("last_invalid",))  # INVALID lines name each one


DECODE = Verb(add_decode_arguments, run_decode)
