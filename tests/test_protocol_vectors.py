"""Every protocol implementation against protocol/vectors.json, and by an independent route."""

import binascii
import random
import struct

import pytest
from cobs import cobs

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import cobs_codec
from tactile_protocol.constants import MAX_ENCODED, PROTOCOL_VERSION
from tactile_protocol.crc16 import crc16
from tactile_protocol.framing import FRAME_OK, FrameAssembler, FrameEncoder
from tactile_protocol.messages import BY_NAME, SPECS, cal_checksum, field_codes


def _values(case, padded=False):
    """The case's field values; ``padded``: strings NUL-padded as they decode."""
    fields = BY_NAME[case["type"]][4]
    codes = BY_NAME[case["type"]][5]
    out = []
    for f, c in zip(fields, codes):
        v = case["fields"][f]
        if c.endswith("s"):
            v = bytes.fromhex(v)
            v = v.ljust(int(c[:-1]), b"\0") if padded else v
        out.append(v)
    return tuple(out)


def test_crc_matches_vectors_and_binascii(vectors):
    assert crc16(b"123456789") == 0x29B1
    for case in vectors["crc16"]:
        data = bytes.fromhex(case["data_hex"])
        assert crc16(data) == case["crc"]
        assert binascii.crc_hqx(data, 0xFFFF) == case["crc"]


def test_cal_checksum_matches_vectors_and_binascii(vectors):
    """HELLO/INFO cal_crc: CRC-16 of SET_CAL's 36 float32 (LE, row-major), PROTOCOL.md §4."""
    names = {c["name"] for c in vectors["cal_checksum"]}
    assert names == {"SET_CAL", "IDENTITY"}
    for case in vectors["cal_checksum"]:
        packed = b"".join(struct.pack("<f", v) for v in case["coeffs"])  # one by one
        assert packed.hex() == case["coeffs_hex"]
        assert binascii.crc_hqx(packed, 0xFFFF) == case["crc"]
        assert cal_checksum(case["coeffs"]) == case["crc"]
    typical = {c["type"]: c for c in vectors["frames"] if c["group"] == "typical"}
    sent = [typical["SET_CAL"]["fields"][f"c{r}{c}"] for r in range(6) for c in range(6)]
    assert typical["INFO"]["fields"]["cal_crc_0"] == cal_checksum(sent)


def test_crc_over_a_window_needs_no_slice():
    data = bytes(range(40))
    assert crc16(data, 5, 30) == crc16(data[5:30])


@pytest.mark.parametrize("impl", ["pure", "cobs-package"])
def test_cobs_vectors(vectors, impl):
    enc, dec = (
        (cobs_codec.encode, cobs_codec.decode) if impl == "pure" else (cobs.encode, cobs.decode)
    )
    groups = {c["group"] for c in vectors["cobs"]}
    assert {"empty", "zeros", "runs", "maximum"} <= groups
    for case in vectors["cobs"]:
        raw, encoded = bytes.fromhex(case["decoded_hex"]), bytes.fromhex(case["encoded_hex"])
        assert enc(raw) == encoded, case["name"]
        assert dec(encoded) == raw, case["name"]
        assert 0 not in encoded


@pytest.mark.parametrize("bad", [b"\x00", b"\x05\x01", b"\x03\x01\x00"])
def test_pure_cobs_rejects_malformed(bad):
    with pytest.raises(ValueError):
        cobs_codec.decode(bad)


def test_every_message_type_has_a_vector(vectors):
    covered = {c["type"] for c in vectors["frames"]}
    assert covered == {name for _, name, _, _ in SPECS}
    assert vectors["protocol_version"] == PROTOCOL_VERSION


def test_frame_encoder_reproduces_vectors(vectors):
    for case in vectors["frames"]:
        encoder = FrameEncoder(seq=case["seq"])
        mtype = case["type_code"]
        frame = bytes(encoder.encode(mtype, case["timestamp_us"], _values(case)))
        assert frame.hex() == case["frame_hex"], (case["type"], case["group"])
        assert len(frame) <= 252


def test_vectors_by_independent_route(vectors):
    """struct + binascii.crc_hqx + the cobs package, written from PROTOCOL.md alone."""
    for case in vectors["frames"]:
        fmt = "<BBHI" + vectors["layouts"][case["type"]]["format"]
        body = struct.pack(
            fmt,
            PROTOCOL_VERSION,
            case["type_code"],
            case["seq"],
            case["timestamp_us"],
            *_values(case),
        )
        body += struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))
        assert (cobs.encode(body) + b"\x00").hex() == case["frame_hex"]


def test_host_decoder_and_board_assembler_read_vectors(vectors):
    """The layout: every vector decodes (the extremes break field limits, checked below)."""
    for case in vectors["frames"]:
        frame = bytes.fromhex(case["frame_hex"])
        (msg,) = StreamDecoder(check_limits=False).feed(frame)
        assert msg.type_name == case["type"]
        assert (msg.seq, msg.timestamp_us) == (case["seq"], case["timestamp_us"])
        assert tuple(msg)[2:] == _values(case, padded=True)
        assembler = FrameAssembler()
        results = [assembler.feed(b) for b in frame]
        assert results[-1] == FRAME_OK
        header = (case["type_code"], case["seq"], case["timestamp_us"])
        assert assembler.message() == (*header, _values(case, padded=True))


def test_typical_vectors_keep_the_field_limits_and_extremes_name_a_field(vectors):
    """With limits: typical frames come out unchanged; an extreme one either keeps the limits
    or comes out INVALID naming one of its own fields (PROTOCOL.md §4, "Field limits")."""
    for case in vectors["frames"]:
        (msg,) = StreamDecoder().feed(bytes.fromhex(case["frame_hex"]))
        if case["group"] == "typical":
            assert msg.type_name == case["type"], msg
        elif msg.type_name == "INVALID":
            assert msg.message == case["type"] and msg.seq == case["seq"]
            assert msg.error.split(" ")[0] in BY_NAME[case["type"]][4], msg.error


def _chunks(data, how, rng):
    if how == "whole":
        return [data]
    if how == "bytewise":
        return [data[i : i + 1] for i in range(len(data))]
    cuts = sorted(rng.sample(range(1, len(data)), min(8, len(data) - 1)))
    return [data[a:b] for a, b in zip([0, *cuts], [*cuts, len(data)])]


@pytest.mark.parametrize("how", ["whole", "bytewise", "random"])
@pytest.mark.parametrize("codec", ["cobs-package", "pure"])
def test_stream_vectors(vectors, how, codec):
    rng = random.Random(3)
    groups = {c["group"] for c in vectors["streams"]}
    assert {"garbage before flag", "frame too short", "crc mismatch", "oversize"} <= groups
    for case in vectors["streams"]:
        decoder = StreamDecoder(cobs_decode=cobs_codec.decode if codec == "pure" else None)
        got = []
        for chunk in _chunks(bytes.fromhex(case["input_hex"]), how, rng):
            got += decoder.feed(chunk)
        assert [m.seq for m in got] == case["delivered_seqs"], case["name"]
        counters = decoder.counters.as_dict()
        assert {k: counters[k] for k in case["counters"]} == case["counters"], case["name"]
        assert counters["invalid"] == 0 and counters["last_invalid"] is None  # not in v1's file


def test_memory_stays_bounded_without_delimiters():
    decoder = StreamDecoder()
    for _ in range(64):
        decoder.feed(b"\x07" * 16384)
    assert decoder.pending_bytes <= MAX_ENCODED
    assert decoder.feed(b"\x00") == []
    assert decoder.counters.oversize == 1


def test_field_codes_expand_counts():
    assert field_codes("BB6i") == ["B", "B"] + ["i"] * 6
    assert field_codes("4I16sH") == ["I"] * 4 + ["16s", "H"]


def test_hello_and_info_end_with_the_board_id(vectors):
    """Version 4 appends the board's unique id (8 bytes) to HELLO and INFO, nothing else."""
    for name in ("HELLO", "INFO"):
        layout = vectors["layouts"][name]
        assert layout["fields"][-1] == "board_id" and layout["format"].endswith("4H8s")
    typical = {c["type"]: c for c in vectors["frames"] if c["group"] == "typical"}
    (msg,) = StreamDecoder().feed(bytes.fromhex(typical["HELLO"]["frame_hex"]))
    assert (
        msg.board_id
        == bytes.fromhex("e6613852834b2c29")
        == bytes.fromhex(typical["HELLO"]["fields"]["board_id"])
    )
    assert msg.to_dict()["board_id"] == "e6613852834b2c29"  # hex, not text


def test_older_hello_and_info_decode_from_recordings_and_are_refused_live(vectors):
    """A HELLO/INFO of versions 1-3 (a recording made then) decodes with the fields its
    version lacks as None; a live decoder counts it as another version and delivers nothing."""
    assert {c["protocol_version"] for c in vectors["older"]} == {1, 2, 3}
    for case in vectors["older"]:
        frame = bytes.fromhex(case["frame_hex"])
        fields = BY_NAME[case["type"]][4]
        (msg,) = StreamDecoder(older=True).feed(frame)
        assert msg.type_name == case["type"] and (msg.seq, msg.timestamp_us) == (7, 123456)
        got = msg._asdict()
        for f in fields:
            want = case["fields"].get(f)
            if isinstance(want, str):
                want = bytes.fromhex(want).ljust(16, b"\0")
            assert got[f] == want, (case["protocol_version"], f)
        assert msg.board_id is None and msg.to_dict()["board_id"] is None
        live = StreamDecoder()
        assert live.feed(frame) == []
        assert (live.counters.version_mismatch, live.counters.last_version) == (
            1,
            case["protocol_version"],
        )


def test_a_version_3_capture_decodes_whole():
    """A capture recorded with protocol 3: its HELLO, samples and a reboot, as they were."""
    from tactile.board.stream_decoder import decode_bytes

    def v3(mtype, seq, ts, fmt, values):
        body = struct.pack("<BBHI" + fmt, 3, mtype, seq, ts, *values)
        return cobs.encode(body + struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))) + b"\0"

    hello_fmt = "BBBB16sBH4IHiiBBI4H"
    hello = (1, 0, 0, 3, b"FT6", 1, 1000, 0, 0, 0, 0, 1000, 5, 4, 3, 1)

    def sample(seq):
        return v3(0x03, seq, 1000 * seq, "BB6i", (0, 0, seq, 0, 0, 0, 0, 0))

    data = v3(0x01, 0, 0, hello_fmt, (*hello, 0xB0071D01, 0, 0, 0, 0)) + sample(1) + sample(2)
    data += v3(0x01, 1, 500, hello_fmt, (*hello, 0xB0071D02, 0, 0, 0, 0)) + sample(2)
    messages, counters = decode_bytes(data)
    assert [m.type_name for m in messages] == ["HELLO", "SAMPLE", "SAMPLE", "HELLO", "SAMPLE"]
    assert (counters.reboots, counters.lost_frames, counters.version_mismatch) == (1, 0, 0)
    assert messages[0].boot_id == 0xB0071D01 and messages[0].board_id is None
