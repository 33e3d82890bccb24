"""``tactile decode CAPTURE.bin [--json]``: raw byte capture -> one message per line.

Damaged input is not an error: it is skipped, counted, and the counters
close the output (exit 0).  A frame whose content breaks the protocol's
limits prints as INVALID, naming the message and the field, and is counted
(``invalid``).  Only an unreadable file is an error (exit 2).  Text and JSON
follow one rule (``tactile.output.text``): device strings are escaped and a
non-finite number is ``null`` in both.
"""

import sys

from tactile.board.stream_decoder import StreamDecoder
from tactile.errors import InputError
from tactile.output.text import dumps, fields, printable

CHUNK = 1 << 16


def add_arguments(parser):
    parser.add_argument("capture", help="raw bytes as read from the serial port")
    parser.add_argument("--json", action="store_true", help="JSON lines (default: readable text)")


def run(args):
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
