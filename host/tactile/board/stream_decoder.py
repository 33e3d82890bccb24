"""Streaming frame decoder: bytes in, messages out, never raises (PROTOCOL.md §5).

``StreamDecoder.feed(data)`` returns the valid messages completed by
``data`` and updates ``counters``.  Memory stays bounded: at most
``MAX_ENCODED`` bytes of an unfinished frame are kept.  Sequence gaps count
as lost frames, except across a reboot (PROTOCOL.md §3: a HELLO or INFO with a
new ``boot_id``, or a HELLO whose timestamp went backwards), which restarts
the count and is counted in ``reboots``.  COBS decoding uses
the C ``cobs`` package when installed and the protocol's pure-Python codec
otherwise; the CRC uses ``binascii.crc_hqx`` (CRC-16/CCITT-FALSE with
init 0xFFFF), both tested against the protocol implementation.

A frame whose content breaks the protocol's field limits
(``tactile_protocol.limits``: a HELLO claiming 5 sensors, a SAMPLE from a
sensor the device never announced) comes out as an ``Invalid`` message naming
the field, counted in ``invalid``; its sequence number still counts, so
refusing it is not mistaken for loss.

A frame of another protocol version is counted (``version_mismatch``, ``last_version``) and
not delivered: a board speaking it cannot be talked to.  ``StreamDecoder(older=True)``, for
reading recordings, delivers frames of the older versions too (``INFO_FIELDS_SINCE``: each
only appended fields to HELLO and INFO), with the fields their HELLO/INFO lacks as None.

**Host-side message objects**, generated from the protocol's one table (``SPECS``).

Each message type is a named tuple ``(seq, timestamp_us, *fields)`` with
class attributes ``type_code`` and ``type_name``.  ``to_dict`` gives the
JSON form used by ``tactile decode``: text fields (``sensor_model``) as text, the binary
``board_id`` as hex digits (None in a HELLO/INFO of a version without it).  Units:
PROTOCOL.md §4.

``Invalid`` stands in for a frame whose framing and layout are good but whose
content breaks the protocol's limits (``tactile_protocol.limits``): it names the
message type it claimed to be and the field that is wrong, and carries none of
the values, so nothing downstream can act on a lie.
"""

import struct
from binascii import crc_hqx
from collections import namedtuple

from tactile_protocol.constants import (
    CRC_SIZE,
    HEADER_SIZE,
    MAX_ENCODED,
    MAX_SENSORS,
    MSG_HELLO,
    MSG_INFO,
    TIMESTAMP_MODULO,
)
from tactile_protocol.constants import PROTOCOL_VERSION as VERSION
from tactile_protocol.limits import RULES, SENSOR, violation
from tactile_protocol.messages import BY_TYPE, INFO_FIELDS_SINCE, SPECS, field_codes

BINARY = ("board_id",)  # bytes fields that are not text


def board_id_text(board_id):
    """A HELLO/INFO ``board_id`` in words: 16 hex digits, or "none" (a version without it)."""
    return "none" if board_id is None else bytes(board_id).hex()


def _to_dict(self):
    out = {"type": self.type_name}
    for name, value in zip(self._fields, self):
        if isinstance(value, bytes):
            binary = name in BINARY
            value = value.hex() if binary else value.rstrip(b"\0").decode("ascii", "replace")
        out[name] = value
    return out


def _make(mtype, name, fields):
    cls = namedtuple(name.title().replace("_", ""), ("seq", "timestamp_us") + tuple(fields))
    cls.type_code = mtype
    cls.type_name = name
    cls.to_dict = _to_dict
    return cls


CLASSES = {mtype: _make(mtype, name, fields) for mtype, name, _, fields in SPECS}
BY_NAME = {cls.type_name: cls for cls in CLASSES.values()}

Hello = BY_NAME["HELLO"]
Info = BY_NAME["INFO"]
Sample = BY_NAME["SAMPLE"]
Contact = BY_NAME["CONTACT"]
Status = BY_NAME["STATUS"]
Ack = BY_NAME["ACK"]
Nak = BY_NAME["NAK"]

INVALID = 0  # not a wire type: the type code of ``Invalid``
Invalid = _make(INVALID, "INVALID", ("message", "error"))


try:  # the C extension of the ``cobs`` package
    from cobs.cobs import DecodeError as _CobsError
    from cobs.cobs import decode as _cobs_decode
except ImportError:  # pragma: no cover - exercised by forcing the fallback in tests
    from tactile_protocol.cobs_codec import decode as _cobs_decode

    _CobsError = ValueError

_DECODE_ERRORS = (_CobsError, ValueError)  # the package's error, the pure codec's

COUNTER_NAMES = (
    "bytes",
    "frames",
    "crc_errors",
    "oversize",
    "undecodable",
    "version_mismatch",
    "seq_gaps",
    "lost_frames",
    "out_of_order",
    "salvaged",
    "reboots",
    "invalid",
)


class Counters:
    """What the decoder saw.  ``lost_frames`` sums the sequence gaps."""

    __slots__ = COUNTER_NAMES + ("last_version", "last_invalid")

    def __init__(self):
        for name in COUNTER_NAMES:
            setattr(self, name, 0)
        self.last_version = None
        self.last_invalid = None  # "HELLO: n_sensors = 5 (protocol allows 1..4)"

    def as_dict(self):
        out = {name: getattr(self, name) for name in COUNTER_NAMES}
        out["last_version"] = self.last_version
        out["last_invalid"] = self.last_invalid
        return out

    @property
    def damaged(self):
        return self.crc_errors + self.oversize + self.undecodable


def _limited(name):
    """None: no field limits; i >= 0: the one limit is a sensor index at message[i] (the
    bulk of a stream, SAMPLE, checked inline); -1: ask ``violation``."""
    rules = RULES.get(name)
    if rules is None:
        return None
    if len(rules) == 1 and rules[0][2] == SENSOR and not rules[0][3]:
        return rules[0][0] + 2  # + seq and timestamp_us
    return -1


def _layouts():
    """type -> (Struct skipping version and type, message class, body length, limited)."""
    out = {}
    for mtype, (_, name, full, size, _, _) in BY_TYPE.items():
        fmt = "<xx" + full[3:]  # skip version and type: unpack gives seq, ts, fields
        out[mtype] = (struct.Struct(fmt), CLASSES[mtype], size, _limited(name))
    return out


_LAYOUTS = _layouts()


def _older_layouts():
    """version -> type -> layout, as ``_layouts`` but HELLO/INFO cut to that version's
    fields (the others as today's: PROTOCOL.md, version history)."""
    out = {}
    for version, n_fields in INFO_FIELDS_SINCE.items():
        layouts = dict(_LAYOUTS)
        for mtype in (MSG_HELLO, MSG_INFO):
            full = BY_TYPE[mtype][2]
            fmt = "<xxHI" + "".join(field_codes(full[len("<BBHI") :])[:n_fields])
            unpacker = struct.Struct(fmt)
            layouts[mtype] = (unpacker, CLASSES[mtype], unpacker.size, -1)
        out[version] = layouts
    return out


_OLDER_LAYOUTS = _older_layouts()
# Encoded length of each type's frame (body + CRC < 254 bytes: COBS adds one byte).
_ENCODED_LENGTHS = sorted({lay[2] + CRC_SIZE + 1 for lay in _LAYOUTS.values()}, reverse=True)


class StreamDecoder:
    """Decode a device's byte stream; see the module docstring."""

    def __init__(self, cobs_decode=None, check_limits=True, older=False):
        self.counters = Counters()
        self._older = older  # also deliver frames of older protocol versions
        self._pending = b""
        self._truncated = False  # the pending span lost its head (too long)
        self._expected_seq = None
        self._boot_id = None  # of the latest HELLO/INFO
        self._last_ts = None  # of the latest frame delivered
        self._decode = cobs_decode or _cobs_decode
        self._check_limits = check_limits  # False: layout only (the golden vectors' extremes)
        self.n_sensors = None  # as the last valid HELLO/INFO announced
        self._sensors = MAX_SENSORS  # sensor indices below this are valid

    @property
    def pending_bytes(self):
        """Bytes of an unfinished frame held (at most MAX_ENCODED)."""
        return len(self._pending)

    def feed(self, data):
        """Add bytes; return the list of messages they completed."""
        c = self.counters
        c.bytes += len(data)
        if self._pending:
            data = self._pending + bytes(data)
        spans = bytes(data).split(b"\0")
        tail = spans.pop()
        out = []
        for span in spans:
            if span:
                if self._truncated:
                    c.oversize += 1
                    self._truncated = False
                    self._salvage(span, out)
                else:
                    self._span(span, out)
            elif self._truncated:
                c.oversize += 1
                self._truncated = False
        if len(tail) > MAX_ENCODED:
            tail = tail[-MAX_ENCODED:]
            self._truncated = True
        self._pending = tail
        return out

    def _span(self, span, out):
        msg = self._parse(span) if len(span) <= MAX_ENCODED else None
        if msg is not None:
            self._deliver(msg, out)
            return
        if len(span) > MAX_ENCODED:
            self.counters.oversize += 1
        self._salvage(span, out)

    def _parse(self, span, count=True):
        """One encoded frame -> message, or None (counted when ``count``)."""
        c = self.counters
        try:
            body = self._decode(span)
        except _DECODE_ERRORS:
            if count:
                c.undecodable += 1
            return None
        n = len(body) - CRC_SIZE
        if n < HEADER_SIZE:
            if count:
                c.undecodable += 1
            return None
        if crc_hqx(body[:n], 0xFFFF) != body[n] | (body[n + 1] << 8):
            if count:
                c.crc_errors += 1
            return None
        layouts = _LAYOUTS
        if body[0] != VERSION:
            layouts = _OLDER_LAYOUTS.get(body[0]) if self._older else None
            if layouts is None:
                if count:
                    c.version_mismatch += 1
                    c.last_version = body[0]
                return None
        layout = layouts.get(body[1])
        if layout is None or layout[2] != n:
            if count:
                c.undecodable += 1
            return None
        values = layout[0].unpack_from(body)
        cls = layout[1]
        if len(values) < len(cls._fields):  # an older HELLO/INFO: the fields it lacks
            return self._older_info(
                cls._make(values + (None,) * (len(cls._fields) - len(values))), body[0]
            )
        msg = cls._make(values)
        limited = layout[3]
        if limited is None or not self._check_limits:
            return msg
        if limited >= 0 and 0 <= msg[limited] < self._sensors:
            return msg
        why = violation(msg.type_name, msg, self.n_sensors, offset=2)
        if why is not None:
            return Invalid(msg.seq, msg.timestamp_us, msg.type_name, why)
        if msg.type_code == MSG_HELLO or msg.type_code == MSG_INFO:
            self.n_sensors = self._sensors = msg.n_sensors
        return msg

    def _older_info(self, msg, version):
        """An older version's HELLO/INFO, checked against the limits of its own version."""
        if not self._check_limits:
            return msg
        why = violation(msg.type_name, msg._replace(protocol_version=VERSION), self.n_sensors, 2)
        if msg.protocol_version != version:
            why = f"protocol_version = {msg.protocol_version} (the frame's version is {version})"
        if why is not None:
            return Invalid(msg.seq, msg.timestamp_us, msg.type_name, why)
        self.n_sensors = self._sensors = msg.n_sensors
        return msg

    def _salvage(self, span, out):
        """Deliver a valid frame at the end of a damaged span (PROTOCOL.md §5)."""
        for length in _ENCODED_LENGTHS:
            if length < len(span):
                msg = self._parse(span[-length:], count=False)
                if msg is not None:
                    self.counters.salvaged += 1
                    self._deliver(msg, out)
                    return

    def _deliver(self, msg, out):
        c = self.counters
        if msg.type_code == INVALID:
            c.invalid += 1
            c.last_invalid = f"{msg.message}: {msg.error}"
        else:
            c.frames += 1
        seq = msg.seq
        expected = self._expected_seq
        if self._rebooted(msg):
            c.reboots += 1
            expected = None  # a new boot's sequence: what it sent before is not loss
        if expected is not None and seq != expected:
            gap = (seq - expected) & 0xFFFF
            if gap < 0x8000:
                c.seq_gaps += 1
                c.lost_frames += gap
            else:
                c.out_of_order += 1
        self._expected_seq = (seq + 1) & 0xFFFF
        self._last_ts = msg.timestamp_us
        out.append(msg)

    def _rebooted(self, msg):
        """A HELLO/INFO with another boot id, or a HELLO from a clock that went back."""
        if msg.type_code != MSG_HELLO and msg.type_code != MSG_INFO:
            return False
        known, self._boot_id = self._boot_id, msg.boot_id
        if known is not None and known != msg.boot_id:
            return True
        if msg.type_code != MSG_HELLO or self._last_ts is None:
            return False
        back = (self._last_ts - msg.timestamp_us) % TIMESTAMP_MODULO
        return 0 < back < TIMESTAMP_MODULO // 2


def decode_bytes(data, chunk=65536):
    """Decode a whole capture (of any protocol version this host reads); return
    ``(messages, counters)``."""
    decoder = StreamDecoder(older=True)
    messages = []
    view = memoryview(data)
    for start in range(0, len(data), chunk):
        messages.extend(decoder.feed(view[start : start + chunk]))
    return messages, decoder.counters
