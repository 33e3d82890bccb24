"""Frames the firmware emits are byte-identical to the protocol's FrameEncoder and vectors."""

import pytest
from fw_rig import Rig, decode_frames, name

from tactile_protocol.constants import (
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    CMD_CONFIG,
    CMD_GET_INFO,
    CMD_PING,
    CMD_START,
    CMD_TARE,
)
from tactile_protocol.framing import FrameEncoder, encode_frame
from tactile_protocol.messages import BY_NAME

DEVICE_TYPES = ("HELLO", "INFO", "SAMPLE", "CONTACT", "STATUS", "ACK", "NAK")


def test_every_emitted_frame_re_encodes_to_the_same_bytes():
    rig = Rig(n=2)
    rig.board.boot()
    raw = bytearray(rig.link.take())
    rig.send(CMD_CONFIG, (1000, 1_000_000, 500_000, 2, CFG_STREAM_SAMPLES | CFG_STREAM_CONTACTS))
    rig.send(CMD_PING)
    rig.send(CMD_GET_INFO)
    rig.send(CMD_TARE, (5, 1))  # NAK: no sensor 5
    rig.send(CMD_START)

    def press(t):
        f = 3_000_000 if 20_000 <= t % 50_000 < 35_000 else -40_000
        return (f, -f // 3, 77, -0x800000, 0x7FFFFF, 5)

    rig.set_codes(0, press)
    rig.set_codes(1, lambda t: (t % 1000, 0, 0, 0, 0, 0))
    for _ in range(10):
        rig.run(10_000)
        raw += rig.link.take()
    frames = decode_frames(bytes(raw))
    kinds = {name(f) for f in frames}
    assert {"HELLO", "INFO", "ACK", "NAK", "STATUS", "SAMPLE", "CONTACT"} <= kinds
    expected = b"".join(encode_frame(t, s, ts, v) for t, s, ts, v in frames)
    assert bytes(raw) == expected
    assert [f[1] for f in frames] == list(range(len(frames)))  # one contiguous sequence


def vector_values(case, padded=True):
    entry = BY_NAME[case["type"]]
    out = []
    for field, code in zip(entry[4], entry[5], strict=True):
        v = case["fields"][field]
        if code.endswith("s"):
            v = bytes.fromhex(v)
        out.append(v)
    return out


def device_cases(vectors):
    return [c for c in vectors["frames"] if c["type"] in DEVICE_TYPES]


def test_vectors_cover_every_device_message(vectors):
    assert {c["type"] for c in device_cases(vectors)} == set(DEVICE_TYPES)


def test_firmware_encode_path_matches_golden_vectors(vectors):
    """The board's way of encoding: one FrameEncoder, reused lists, check=False."""
    enc = FrameEncoder()
    buffers = {}
    for case in device_cases(vectors):
        values = buffers.setdefault(case["type"], [0] * len(BY_NAME[case["type"]][4]))
        values[:] = vector_values(case)
        enc.seq = case["seq"]
        frame = enc.encode(case["type_code"], case["timestamp_us"], values, False)
        assert bytes(frame).hex() == case["frame_hex"], case["group"]


@pytest.mark.parametrize("kind", ["SAMPLE", "CONTACT"])
def test_board_stream_frame_equals_a_vector(vectors, kind):
    """The board's own emit path, set to a vector's values, gives the vector's bytes."""
    case = next(c for c in vectors["frames"] if c["type"] == kind and c["group"] == "typical")
    f = case["fields"]
    s = f["sensor"]
    rig = Rig(n=s + 1)
    rig.board.boot()
    flags = CFG_STREAM_SAMPLES if kind == "SAMPLE" else CFG_STREAM_CONTACTS
    rig.config(rate=500, enter=0, exit_=0, debounce=1, flags=flags)
    rig.command(CMD_START)
    board = rig.board
    # identity calibration (1 uN per count): a bias of -F/T puts zero counts at the values
    board.cals[s].set_bias([-f[k] for k in ("fx", "fy", "fz", "tx", "ty", "tz")])
    board.sensors[s].counts[:] = [0] * 6
    board.gates[s].reset()
    board.gates[s].contact_id = f.get("contact_id", 1) - 1
    board.enc.seq = case["seq"]
    board.time_us = case["timestamp_us"]
    board._late = False
    board._emit(s, 0)
    assert rig.link.take().hex() == case["frame_hex"]
