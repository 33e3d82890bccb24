"""Property-based tests of the protocol (hypothesis): identity, damage tolerance, range checks."""

import pytest
from conftest import FUZZ_SCALE
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import cobs_codec
from tactile_protocol.constants import MSG_SAMPLE
from tactile_protocol.framing import FrameEncoder, encode_frame
from tactile_protocol.limits import violation
from tactile_protocol.messages import BY_NAME, BY_TYPE, SPECS, check_fields

_INT = {"B": (0, 0xFF), "H": (0, 0xFFFF), "I": (0, 0xFFFFFFFF), "i": (-(2**31), 2**31 - 1)}


def _field(code):
    if code.endswith("s"):
        return st.binary(max_size=int(code[:-1])).map(lambda b: b.rstrip(b"\0"))
    if code == "f":
        return st.floats(width=32, allow_nan=False, allow_infinity=False)
    return st.integers(*_INT[code])


@st.composite
def messages(draw, names=None):
    name = draw(st.sampled_from(names or [n for _, n, _, _ in SPECS]))
    mtype, _, _, _, fields, codes = BY_NAME[name]
    values = tuple(draw(_field(c)) for c in codes)
    seq = draw(st.integers(0, 0xFFFF))
    ts = draw(st.integers(0, 0xFFFFFFFF))
    return mtype, seq, ts, values


@settings(max_examples=400, deadline=None)
@given(messages())
def test_encode_decode_identity(message):
    mtype, seq, ts, values = message
    frame = encode_frame(mtype, seq, ts, values)
    assert len(frame) <= 252 and frame.index(0) == len(frame) - 1
    (msg,) = StreamDecoder(check_limits=False).feed(frame)
    codes = BY_TYPE[mtype][5]
    expect = tuple(
        v.ljust(int(c[:-1]), b"\0") if c.endswith("s") else v for v, c in zip(values, codes)
    )
    assert msg.type_code == mtype and (msg.seq, msg.timestamp_us) == (seq, ts)
    assert tuple(msg)[2:] == expect
    # With the field limits: the same message, or INVALID naming what the limits name.
    (checked,) = StreamDecoder().feed(frame)
    why = violation(BY_TYPE[mtype][1], expect)
    assert checked == (msg if why is None else (seq, ts, BY_TYPE[mtype][1], why))


def _out_of_range_cases():
    for mtype, name, _, _, fields, codes in BY_TYPE.values():
        for i, (field, code) in enumerate(zip(fields, codes)):
            if code.endswith("s"):
                bad = b"x" * (int(code[:-1]) + 1)
            elif code == "f":
                bad = float("nan")
            else:
                bad = _INT[code][1] + 1
            yield pytest.param(mtype, i, bad, f"{name}.{field}", id=f"{name}.{field}")


@pytest.mark.parametrize("mtype, index, bad, label", list(_out_of_range_cases()))
def test_out_of_range_field_is_named(mtype, index, bad, label):
    codes = BY_TYPE[mtype][5]
    values = [b"" if c.endswith("s") else 0 for c in codes]
    values[index] = bad
    with pytest.raises(ValueError, match=label.replace(".", r"\.")):
        check_fields(mtype, 0, 0, values)


def test_header_fields_are_checked():
    with pytest.raises(ValueError, match=r"SAMPLE\.seq"):
        check_fields(MSG_SAMPLE, 65536, 0, (0,) * 8)
    with pytest.raises(ValueError, match=r"SAMPLE\.timestamp_us"):
        check_fields(MSG_SAMPLE, 0, -1, (0,) * 8)
    with pytest.raises(ValueError, match="expected 8 fields"):
        check_fields(MSG_SAMPLE, 0, 0, (0,) * 7)


def _damage(frame, kind, data):
    if kind == "flip":
        i = data.draw(st.integers(0, len(frame) - 1))
        bit = data.draw(st.integers(0, 7))
        out = bytearray(frame)
        out[i] ^= 1 << bit
        return bytes(out)
    if kind == "truncate":
        return frame[: data.draw(st.integers(0, len(frame) - 1))]
    i = data.draw(st.integers(0, len(frame) - 1))  # "drop"
    return frame[:i] + frame[i + 1 :]


@settings(
    max_examples=300 * FUZZ_SCALE, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@pytest.mark.slow
@given(st.data())
def test_damage_loses_only_damaged_frames(data):
    """Garbage between frames and damaged frames: never raises, delivers every intact frame.

    The first and last frames stay intact so every loss is visible as a sequence gap,
    and ``lost_frames`` then equals the number of damaged frames exactly.
    """
    n = data.draw(st.integers(3, 25))
    encoder = FrameEncoder()
    frames = [
        bytes(encoder.encode(MSG_SAMPLE, 1000 * i, (0, 0, i, -i, 7, 0, 0, 0))) for i in range(n)
    ]
    damaged = set()
    stream = b""
    for i, frame in enumerate(frames):
        if 0 < i < n - 1 and data.draw(st.booleans()):
            kind = data.draw(st.sampled_from(["flip", "truncate", "drop"]))
            frame = _damage(frame, kind, data)
            damaged.add(i)
        stream += frame
        if data.draw(st.integers(0, 4)) == 0:
            stream += data.draw(st.binary(min_size=1, max_size=300))
    decoder = StreamDecoder()
    cut = data.draw(st.integers(0, len(stream)))
    got = decoder.feed(stream[:cut]) + decoder.feed(stream[cut:])
    got_seqs = [m.seq for m in got if m.type_name == "SAMPLE"]
    intact = [i for i in range(n) if i not in damaged]
    assert [s for s in got_seqs if s in intact] == intact
    assert set(got_seqs) <= set(range(n))
    if set(got_seqs) == set(intact):
        assert decoder.counters.lost_frames == len(damaged)
    assert decoder.pending_bytes <= 251


@settings(max_examples=200 * FUZZ_SCALE, deadline=None)
@given(st.binary(max_size=3000))
def test_arbitrary_bytes_never_raise(blob):
    decoder = StreamDecoder()
    for i in range(0, len(blob), 97):
        decoder.feed(blob[i : i + 97])
    c = decoder.counters
    assert c.bytes == len(blob)
    assert decoder.pending_bytes <= 251


def test_flipped_payload_bits_are_counted_exactly():
    """A payload bit flipped after the CRC was computed (re-encoded, so COBS stays valid)."""
    encoder = FrameEncoder()
    stream = b""
    for i in range(50):
        frame = bytes(encoder.encode(MSG_SAMPLE, i, (0, 0, 1 + i, 2, 3, 4, 5, 6)))
        if i % 5 == 2:
            body = bytearray(cobs_codec.decode(frame[:-1]))
            body[10] ^= 0x10
            frame = cobs_codec.encode(bytes(body)) + b"\0"
        stream += frame
    decoder = StreamDecoder()
    got = decoder.feed(stream)
    assert len(got) == 40
    assert decoder.counters.crc_errors == 10
    assert decoder.counters.lost_frames == 10 and decoder.counters.seq_gaps == 10
