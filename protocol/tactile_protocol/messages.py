"""Message layouts and their packing (PROTOCOL.md §4).

One table, ``SPECS``, defines every message: type code, name, payload
``struct`` format and field names.  Every payload has a fixed length per
type, which the host's resynchronisation relies on.  All fields are
little-endian.  ``pack_into`` validates ranges and raises ValueError naming
the message and field; ``unpack`` checks version, type and length.

Each version so far changed one thing: it appended fields to HELLO and INFO.  A frame of
an older version therefore has today's layout, except that its HELLO or INFO holds only the
first ``INFO_FIELDS_SINCE[version]`` fields (a host reads recordings of those versions).
"""

import struct

from tactile_protocol.constants import (
    CMD_CONFIG,
    CMD_GET_INFO,
    CMD_PING,
    CMD_SET_CAL,
    CMD_START,
    CMD_STOP,
    CMD_TARE,
    HEADER_SIZE,
    MSG_ACK,
    MSG_CONTACT,
    MSG_HELLO,
    MSG_INFO,
    MSG_NAK,
    MSG_SAMPLE,
    MSG_STATUS,
    PROTOCOL_VERSION,
)
from tactile_protocol.crc16 import crc16

HEADER_FMT = "<BBHI"

_FT = ("fx", "fy", "fz", "tx", "ty", "tz")
_CONFIG = ("rate_hz", "enter_threshold", "exit_threshold", "debounce", "flags")
_INFO = (
    (
        "fw_major",
        "fw_minor",
        "fw_patch",
        "protocol_version",
        "sensor_model",
        "n_sensors",
        "max_rate_hz",
        "cal_id_0",
        "cal_id_1",
        "cal_id_2",
        "cal_id_3",
    )
    + _CONFIG
    + ("boot_id", "cal_crc_0", "cal_crc_1", "cal_crc_2", "cal_crc_3", "board_id")
)
_CAL = ("sensor", "cal_id") + tuple("c%d%d" % (r, c) for r in range(6) for c in range(6))

# (type, name, payload format without byte-order prefix, field names)
SPECS = (
    (MSG_HELLO, "HELLO", "BBBB16sBH4IHiiBBI4H8s", _INFO),
    (MSG_INFO, "INFO", "BBBB16sBH4IHiiBBI4H8s", _INFO),
    (MSG_SAMPLE, "SAMPLE", "BB6i", ("sensor", "flags") + _FT),
    (MSG_CONTACT, "CONTACT", "BBHB6i", ("sensor", "phase", "contact_id", "flags") + _FT),
    (
        MSG_STATUS,
        "STATUS",
        "HBB6I",
        (
            "faults",
            "sensor",
            "last_error",
            "i2c_errors",
            "drdy_timeouts",
            "saturations",
            "overruns",
            "tx_dropped",
            "samples",
        ),
    ),
    (MSG_ACK, "ACK", "BH", ("cmd_type", "cmd_seq")),
    (MSG_NAK, "NAK", "BHBB", ("cmd_type", "cmd_seq", "reason", "detail")),
    (CMD_PING, "PING", "", ()),
    (CMD_GET_INFO, "GET_INFO", "", ()),
    (CMD_CONFIG, "CONFIG", "HiiBB", _CONFIG),
    (CMD_TARE, "TARE", "BH", ("sensor", "n_samples")),
    (CMD_START, "START", "", ()),
    (CMD_STOP, "STOP", "", ()),
    (CMD_SET_CAL, "SET_CAL", "BI36f", _CAL),
)

# HELLO / INFO fields per older protocol version: 1 ends at flags, 2 adds boot_id, 3 the
# cal_crc_N (today's version adds board_id).
INFO_FIELDS_SINCE = {1: 16, 2: 17, 3: 21}

_FLOAT32_MAX = 3.4028234663852886e38
_RANGES = {
    "B": (0, 0xFF),
    "H": (0, 0xFFFF),
    "I": (0, 0xFFFFFFFF),
    "i": (-0x80000000, 0x7FFFFFFF),
}


def field_codes(fmt):
    """Split a payload format into one code per field: "B4I16s" -> B I I I I 16s."""
    codes = []
    count = ""
    for ch in fmt:
        if "0" <= ch <= "9":
            count += ch
        elif ch == "s":
            codes.append(count + "s")
            count = ""
        else:
            codes.extend([ch] * int(count or "1"))
            count = ""
    return codes


def _build_index():
    by_type = {}
    by_name = {}
    for mtype, name, fmt, fields in SPECS:
        full = HEADER_FMT + fmt
        codes = field_codes(fmt)
        if len(codes) != len(fields):
            raise AssertionError(name)
        entry = (mtype, name, full, struct.calcsize(full), fields, codes)
        by_type[mtype] = entry
        by_name[name] = entry
    return by_type, by_name


BY_TYPE, BY_NAME = _build_index()


def _check(name, field, code, value):
    if code.endswith("s"):
        if not isinstance(value, (bytes, bytearray)) or len(value) > int(code[:-1]):
            raise ValueError("%s.%s: expected at most %s bytes" % (name, field, code[:-1]))
        return
    if code == "f":
        v = float(value)
        if v != v or v > _FLOAT32_MAX or v < -_FLOAT32_MAX:
            raise ValueError("%s.%s: %r is not a finite float32" % (name, field, value))
        return
    lo, hi = _RANGES[code]
    if not isinstance(value, int) or value < lo or value > hi:
        raise ValueError("%s.%s: %r out of range [%d, %d]" % (name, field, value, lo, hi))


def check_fields(mtype, seq, timestamp_us, values):
    """Raise ValueError naming the first field that cannot be encoded."""
    entry = BY_TYPE.get(mtype)
    if entry is None:
        raise ValueError("type: unknown message type %r" % (mtype,))
    name, fields, codes = entry[1], entry[4], entry[5]
    if len(values) != len(fields):
        raise ValueError("%s: expected %d fields, got %d" % (name, len(fields), len(values)))
    _check(name, "seq", "H", seq)
    _check(name, "timestamp_us", "I", timestamp_us)
    for i in range(len(fields)):
        _check(name, fields[i], codes[i], values[i])


def pack_into(buf, mtype, seq, timestamp_us, values, check=True):
    """Write header + payload at the start of ``buf``; return its length."""
    if check:
        check_fields(mtype, seq, timestamp_us, values)
    entry = BY_TYPE[mtype]
    struct.pack_into(entry[2], buf, 0, PROTOCOL_VERSION, mtype, seq, timestamp_us, *values)
    return entry[3]


def unpack(body, n=None):
    """Parse header + payload (CRC already stripped and checked).

    Returns ``(mtype, seq, timestamp_us, values)``; ValueError when the
    version, type or length is wrong.
    """
    if n is None:
        n = len(body)
    if n < HEADER_SIZE:
        raise ValueError("frame shorter than the header")
    if body[0] != PROTOCOL_VERSION:
        raise ValueError("protocol version %d, expected %d" % (body[0], PROTOCOL_VERSION))
    entry = BY_TYPE.get(body[1])
    if entry is None:
        raise ValueError("unknown message type 0x%02x" % body[1])
    if n != entry[3]:
        raise ValueError("%s: %d bytes, expected %d" % (entry[1], n, entry[3]))
    values = struct.unpack_from(entry[2], body, 0)
    return values[1], values[2], values[3], values[4:]


CAL_COEFFS_FMT = "<36f"  # SET_CAL's c00..c55 as they travel: float32, little-endian, row-major


def cal_checksum(coeffs):
    """HELLO/INFO ``cal_crc_N``: CRC-16/CCITT-FALSE of the 36 coefficients as SET_CAL sends them.

    ``coeffs`` are 36 numbers (row-major); each is rounded to float32 first, exactly as
    packing SET_CAL does, so host and device hash the same 144 bytes.
    """
    return crc16(struct.pack(CAL_COEFFS_FMT, *coeffs))
