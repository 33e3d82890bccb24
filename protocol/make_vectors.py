"""Generate vectors.json, the golden bytes of the protocol version in force (PROTOCOL.md §6).

Run once per protocol version: ``python protocol/make_vectors.py``.  The
file is then frozen; tests compare every implementation with it.  Frame
bytes come from ``tactile_protocol``; stream counters come from the host
decoder acting as the oracle, after the delivered frames (and, where a case
states them, the counters the spec fixes) are checked against the
expectation written next to each case.
"""

import json
import os
import random
import struct

from tactile_protocol import constants as C
from tactile_protocol.cobs_codec import encode
from tactile_protocol.crc16 import crc16
from tactile_protocol.framing import encode_frame
from tactile_protocol.messages import (
    BY_NAME,
    INFO_FIELDS_SINCE,
    SPECS,
    cal_checksum,
    field_codes,
)

HERE = os.path.dirname(os.path.abspath(__file__))


def _hex(b):
    return bytes(b).hex()


def crc_cases():
    data = [b"123456789", b"", b"\x00", bytes(range(256)), b"\xff" * 32]
    return [{"data_hex": _hex(d), "crc": crc16(d)} for d in data]


def cobs_cases():
    rng = random.Random(7)
    nz = bytes(rng.randrange(1, 256) for _ in range(600))
    cases = [
        ("empty", "empty payload", b""),
        ("zeros", "one zero", b"\x00"),
        ("zeros", "two zeros", b"\x00\x00"),
        ("zeros", "zeros inside", b"\x11\x22\x00\x33"),
        ("zeros", "zero at the end", b"\x11\x22\x33\x44\x00"),
        ("zeros", "all zeros, maximum body", bytes(C.MAX_BODY)),
        ("runs", "253 non-zero bytes", nz[:253]),
        ("runs", "254 non-zero bytes", nz[:254]),
        ("runs", "255 non-zero bytes", nz[:255]),
        ("runs", "254 non-zero then zero", nz[:254] + b"\x00"),
        ("runs", "zero then 254 non-zero", b"\x00" + nz[:254]),
        ("runs", "508 non-zero bytes", nz[:508]),
        ("maximum", "maximum body, mixed", bytes(rng.choice((0, 1, 255, 7)) for _ in range(250))),
    ]
    return [
        {"group": g, "name": n, "decoded_hex": _hex(d), "encoded_hex": _hex(encode(d))}
        for g, n, d in cases
    ]


def _extreme(code, high):
    if code.endswith("s"):
        return b"\xff" * int(code[:-1]) if high else b""
    if code == "f":
        return 3.4028234663852886e38 if high else -1.5
    lo_hi = {"B": (0, 255), "H": (0, 65535), "I": (0, 0xFFFFFFFF), "i": (-(2**31), 2**31 - 1)}
    return lo_hi[code][1 if high else 0]


TYPICAL = {
    "HELLO": (
        1,
        0,
        0,
        C.PROTOCOL_VERSION,
        b"SIM-ADS1219x6",
        1,
        1000,
        17,
        0,
        0,
        0,
        1000,
        5000000,
        4000000,
        3,
        0x0A,
        0x5EED1D01,
        0x6B1D,
        0,
        0,
        0,
        bytes.fromhex("e6613852834b2c29"),  # as an RP2040's flash answers 0x4B
    ),
    "INFO": (
        1,
        0,
        0,
        C.PROTOCOL_VERSION,
        b"SIM-ADS1219x6",
        3,
        1000,
        1,
        2,
        3,
        0,
        500,
        5000000,
        4000000,
        2,
        0x23,
        0x5EED1D01,
        "SET_CAL",  # replaced below by cal_checksum(TYPICAL SET_CAL's matrix)
        "IDENTITY",
        0xFFFF,
        0,
        bytes.fromhex("0102030405060708"),
    ),
    "SAMPLE": (0, 0x40, 1234567, -2345678, 45, -1000, 2000, 0),
    "CONTACT": (2, C.PHASE_BEGIN, 7, 0x40, 5100000, 0, -12, 1, 2, 3),
    "STATUS": (C.FAULT_I2C | C.FAULT_RECOVERED, 0xFF, 5, 3, 0, 1, 2, 4, 100000),
    "ACK": (C.CMD_CONFIG, 41),
    "NAK": (C.CMD_CONFIG, 42, C.NAK_OUT_OF_RANGE, 0),
    "PING": (),
    "GET_INFO": (),
    "CONFIG": (1000, 5000000, 4000000, 3, C.CFG_STREAM_CONTACTS | C.CFG_AUTOSTART),
    "TARE": (0xFF, 64),
    "START": (),
    "STOP": (),
    "SET_CAL": (0, 20260101) + tuple(float(i - 17) / 8 for i in range(36)),
}
IDENTITY_1UN = tuple(1e-6 if r == c else 0.0 for r in range(6) for c in range(6))
CAL_CASES = (("SET_CAL", TYPICAL["SET_CAL"][2:]), ("IDENTITY", IDENTITY_1UN))
TYPICAL["INFO"] = tuple(
    cal_checksum(dict(CAL_CASES)[v]) if isinstance(v, str) else v for v in TYPICAL["INFO"]
)


def cal_checksum_cases():
    """HELLO/INFO cal_crc: the typical SET_CAL matrix and the firmware's 1 uN/count identity."""
    return [
        {"name": n, "coeffs": list(c), "coeffs_hex": _hex(struct.pack("<36f", *c)),
         "crc": cal_checksum(c)}
        for n, c in CAL_CASES
    ]  # fmt: skip


# Frames added within a protocol version (a new value of a field, no layout change), after
# the frozen cases so that those keep their place: (group, type, seq, timestamp, values).
ADDED = (("typical", "NAK", 514, 1000500, (C.CMD_TARE, 43, C.NAK_LOADED, 1)),)


def _fields_json(name, values):
    fields = BY_NAME[name][4]
    return {f: (v.hex() if isinstance(v, bytes) else v) for f, v in zip(fields, values)}


def frame_cases():
    cases = []
    for name, values in TYPICAL.items():
        cases.append(("typical", name, 513, 1000000, values))
        codes = BY_NAME[name][5]
        if codes:
            for high in (False, True):
                ext = tuple(_extreme(c, high) for c in codes)
                label = "maximum" if high else "minimum"
                cases.append((label, name, 65535 if high else 0, 0xFFFFFFFF if high else 0, ext))
    cases += ADDED
    out = []
    for group, name, seq, ts, values in cases:
        mtype = BY_NAME[name][0]
        frame = encode_frame(mtype, seq, ts, values)
        body = bytes.fromhex(_hex(frame))  # copy
        out.append(
            {
                "group": group,
                "type": name,
                "type_code": mtype,
                "seq": seq,
                "timestamp_us": ts,
                "fields": _fields_json(name, values),
                "frame_hex": _hex(frame),
                "body_len": len(body) - 2,
            }
        )
    return out


def older_cases():
    """HELLO and INFO as each older version sent them (today's fields, cut to that version's:
    ``INFO_FIELDS_SINCE``), which a reader of recordings made then still decodes."""
    out = []
    for version, n_fields in sorted(INFO_FIELDS_SINCE.items()):
        for name in ("HELLO", "INFO"):
            mtype, fields = BY_NAME[name][0], BY_NAME[name][4][:n_fields]
            values = list(TYPICAL[name][:n_fields])
            values[fields.index("protocol_version")] = version
            fmt = "".join(BY_NAME[name][5][:n_fields])
            body = struct.pack("<BBHI" + fmt, version, mtype, 7, 123456, *values)
            crc = crc16(body)
            frame = encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\x00"
            out.append(
                {
                    "protocol_version": version,
                    "type": name,
                    "seq": 7,
                    "timestamp_us": 123456,
                    "format": fmt,
                    "fields": _fields_json(name, values),
                    "frame_hex": _hex(frame),
                }
            )
    return out


def _sample(seq):
    return encode_frame(C.MSG_SAMPLE, seq, 1000 * seq, (0, 0, seq, -seq, 3, 4, 5, 6))


def _flipped(seq):
    """SAMPLE ``seq`` with one payload bit flipped after its CRC was computed."""
    body = bytearray(struct.pack("<BBHI", C.PROTOCOL_VERSION, C.MSG_SAMPLE, seq, 1000 * seq))
    body += struct.pack("<BB6i", 0, 0, seq, -seq, 3, 4, 5, 6)
    crc = crc16(body)
    body[12] ^= 0x04
    return encode(bytes(body) + bytes((crc & 0xFF, crc >> 8))) + b"\x00"


def _hello(seq, ts, boot_id):
    fields = BY_NAME["HELLO"][4]
    values = list(TYPICAL["HELLO"])
    values[fields.index("boot_id")] = boot_id
    return encode_frame(C.MSG_HELLO, seq, ts, values)


def stream_cases():
    """(group, name, bytes, seqs that must be delivered, counters the spec fixes)."""
    f = [_sample(i) for i in range(8)]
    flip = _flipped(1)
    garbage = bytes([0x13, 0x37, 0xAA])
    old = C.PROTOCOL_VERSION - 1  # a device speaking the previous version
    body = bytearray(struct.pack("<BBHI", old, C.MSG_SAMPLE, 9, 0) + bytes(26))
    c = crc16(body)
    body += bytes((c & 0xFF, c >> 8))
    other_version = encode(body) + b"\x00"
    return [
        ("clean", "three frames", f[0] + f[1] + f[2], [0, 1, 2]),
        ("clean", "idle delimiters between frames", b"\x00\x00" + f[0] + b"\x00" + f[1], [0, 1]),
        ("garbage before flag", "garbage then delimiter", garbage + b"\x00" + f[0] + f[1], [0, 1]),
        ("garbage before flag", "garbage glued to a frame", garbage + f[0] + f[1], [0, 1]),
        ("frame too short", "three bytes", b"\x04\x01\x02\x03\x00" + f[0], [0]),
        ("truncated", "frame cut before its delimiter", f[0][:-7] + f[1] + f[2], [1, 2]),
        ("crc mismatch", "one flipped bit", f[0] + bytes(flip) + f[2], [0, 2]),
        ("dropped byte", "delimiter lost", f[0][:-1] + f[1] + f[2], [1, 2]),
        ("dropped byte", "byte lost mid-frame", f[0][:9] + f[0][10:] + f[1], [1]),
        ("oversize", "300 bytes without delimiter", b"\x01" * 300 + b"\x00" + f[3], [3]),
        ("oversize", "long garbage glued to a frame", b"\x05" * 400 + f[4] + f[5], [4, 5]),
        ("version", f"frame of protocol version {old}", other_version + f[0], [0]),
        ("sequence", "gap of two frames", f[0] + f[3] + f[4], [0, 3, 4]),
        # §3: serial links do not reorder; a swap counts as two lost and one out of order
        ("sequence", "adjacent frames swapped", f[0] + f[2] + f[1] + f[3], [0, 2, 1, 3],
         {"lost_frames": 2, "seq_gaps": 2, "out_of_order": 1}),
        ("reboot", "HELLO with a new boot id restarts the count",
         _hello(0, 0, 0xB0071D01) + f[1] + f[2] + _hello(1, 50_000, 0xB0071D02) + f[2],
         [0, 1, 2, 1, 2], {"lost_frames": 0, "out_of_order": 0, "reboots": 1}),
        ("reboot", "HELLO of the same boot after a gap: the gap is loss",
         _hello(0, 0, 0xB0071D01) + f[1] + f[2] + _hello(5, 5000, 0xB0071D01) + f[6],
         [0, 1, 2, 5, 6], {"lost_frames": 2, "reboots": 0}),
        ("reboot", "HELLO whose timestamp went back (no boot id seen before)",
         f[3] + f[4] + _hello(1, 500, 0xB0071D01) + f[2], [3, 4, 1, 2],
         {"lost_frames": 0, "out_of_order": 0, "reboots": 1}),
    ]  # fmt: skip


def decode_case(data):
    from tactile.board.stream_decoder import StreamDecoder  # the oracle (host package)

    whole = StreamDecoder()
    got = whole.feed(data)
    return [m.seq for m in got], whole.counters.as_dict()


def main():
    streams = []
    for group, name, data, expect, *fixed in stream_cases():
        seqs, counters = decode_case(data)
        if seqs != expect:
            raise SystemExit(f"stream case {name!r}: oracle delivered {seqs}, spec says {expect}")
        wrong = {k: counters[k] for k, v in (fixed or [{}])[0].items() if counters[k] != v}
        if wrong:
            raise SystemExit(f"stream case {name!r}: oracle counted {wrong}, spec says {fixed}")
        streams.append(
            {
                "group": group,
                "name": name,
                "input_hex": _hex(data),
                "delivered_seqs": seqs,
                "counters": counters,
            }
        )
    doc = {
        "protocol_version": C.PROTOCOL_VERSION,
        "limits": {
            "max_payload": C.MAX_PAYLOAD,
            "max_body": C.MAX_BODY,
            "max_encoded": C.MAX_ENCODED,
            "max_frame": C.MAX_FRAME,
        },
        "layouts": {
            name: {"type_code": t, "format": fmt, "fields": list(fields)}
            for t, name, fmt, fields in SPECS
        },
        "crc16": crc_cases(),
        "cal_checksum": cal_checksum_cases(),
        "cobs": cobs_cases(),
        "frames": frame_cases(),
        "older": older_cases(),
        "streams": streams,
    }
    with open(os.path.join(HERE, "vectors.json"), "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


if __name__ == "__main__":
    assert field_codes("B4I16s") == ["B", "I", "I", "I", "I", "16s"]
    main()
