"""Command validation: every command gets ACK or NAK; refused values are never applied."""

import binascii
import struct

import pytest
from fw_rig import Rig, name, replies

from tactile_fw import calibration, settings
from tactile_protocol.cobs_codec import encode as cobs_encode
from tactile_protocol.constants import (
    CFG_AUTOSTART,
    CFG_PERSIST,
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    CFG_STREAMING,
    CMD_CONFIG,
    CMD_GET_INFO,
    CMD_PING,
    CMD_SET_CAL,
    CMD_START,
    CMD_STOP,
    CMD_TARE,
    NAK_BAD_LENGTH,
    NAK_BAD_STATE,
    NAK_BAD_VERSION,
    NAK_DETAIL_NONE,
    NAK_HARDWARE,
    NAK_OUT_OF_RANGE,
    NAK_STORAGE,
    NAK_UNKNOWN_COMMAND,
    PROTOCOL_VERSION,
)
from tactile_protocol.crc16 import crc16


@pytest.fixture
def rig():
    r = Rig()
    r.board.boot()
    r.frames()
    return r


def only_reply(frames, seq):
    rs = replies(frames, seq)
    assert len(rs) == 1, frames
    return rs[0]


def info(rig):
    seq, frames = rig.command(CMD_GET_INFO)
    assert name(only_reply(frames, seq)) == "ACK"
    (inf,) = [f for f in frames if name(f) == "INFO"]
    return dict(
        zip(
            (
                "fw_major",
                "fw_minor",
                "fw_patch",
                "proto",
                "model",
                "n",
                "max_rate",
                "cal0",
                "cal1",
                "cal2",
                "cal3",
                "rate",
                "enter",
                "exit",
                "debounce",
                "flags",
                "boot_id",
                "crc0",
                "crc1",
                "crc2",
                "crc3",
                "board_id",
            ),
            inf[3],
            strict=True,
        )
    )


def test_hello_at_boot_is_seq_zero_and_on_port_open(rig):
    assert rig.log[0][0] == 0x01 and rig.log[0][1] == 0
    rig.link.host_open()
    rig.run(1000)
    assert [name(f) for f in rig.frames()] == ["HELLO"]


def test_ping_and_get_info(rig):
    seq, frames = rig.command(CMD_PING)
    assert only_reply(frames, seq)[3] == (CMD_PING, seq)
    i = info(rig)
    assert i["model"].rstrip(b"\0") == b"FT6/ADS122C04x6"
    assert i["max_rate"] == rig.board.max_rate_hz == 1730
    assert (i["rate"], i["enter"], i["exit"], i["debounce"]) == (1000, 1_390_000, 1_112_000, 3)


@pytest.mark.parametrize(
    "given, sent",
    [
        (bytes.fromhex("e6613852834b2c29"), "e6613852834b2c29"),  # an RP2040's: as it is
        (b"\x01\x02\x03\x04\x05\x06", "0102030405060000"),  # shorter: NUL-padded
        (bytes(range(1, 11)), "0808030405060708"),  # longer: folded (1 ^ 9, 2 ^ 10, 3, ...)
    ],
)
def test_hello_and_info_carry_the_board_id_the_entry_point_gives(given, sent):
    r = Rig(board_id=given)
    r.board.boot()
    (hello,) = [f for f in r.frames() if name(f) == "HELLO"]  # the power-up HELLO
    assert hello[3][-1].hex() == sent
    assert info(r)["board_id"].hex() == sent
    bare = Rig()
    bare.board.boot()
    assert info(bare)["board_id"] == bytes(8)  # none given: a board without an id


def test_config_applies_and_info_reports_it(rig):
    seq, frames = rig.config(rate=500, enter=2_000_000, exit_=1_500_000, debounce=4, flags=0x05)
    assert name(only_reply(frames, seq)) == "ACK"
    i = info(rig)
    assert (i["rate"], i["enter"], i["exit"], i["debounce"], i["flags"]) == (
        500,
        2_000_000,
        1_500_000,
        4,
        0x05,
    )
    assert rig.board.sched.period_us == 2000
    assert rig.board.gates[0].three_d


@pytest.mark.parametrize(
    "values, field",
    [
        ((0, 10, 5, 1, 0), 0),  # rate 0
        ((1740, 10, 5, 1, 0), 0),  # above the ceiling (1730 Hz)
        ((100, -1, -2, 1, 0), 1),  # negative enter
        ((100, 10, 11, 1, 0), 2),  # exit above enter
        ((100, 10, -1, 1, 0), 2),  # negative exit
        ((100, 10, 5, 0, 0), 3),  # debounce 0
        ((100, 10, 5, 1, 0x40), 4),  # unknown flag
        ((100, 10, 5, 1, CFG_STREAMING), 4),  # read-only flag
    ],
)
def test_config_out_of_range_is_refused_with_the_field_index(rig, values, field):
    before = rig.board.settings.fields()
    seq, frames = rig.command(CMD_CONFIG, values)
    nak = only_reply(frames, seq)
    assert name(nak) == "NAK" and nak[3] == (CMD_CONFIG, seq, NAK_OUT_OF_RANGE, field)
    assert rig.board.settings.fields() == before
    assert rig.storage.read(settings.FILE_NAME) is None


def test_ceiling_accepted_exactly(rig):
    seq, frames = rig.config(rate=1730)
    assert name(only_reply(frames, seq)) == "ACK"


def test_config_persist_and_autostart_survive_reboot(rig):
    flags = CFG_STREAM_SAMPLES | CFG_AUTOSTART | CFG_PERSIST
    seq, frames = rig.config(rate=250, flags=flags)
    assert name(only_reply(frames, seq)) == "ACK"
    assert rig.board.settings.flags == CFG_STREAM_SAMPLES | CFG_AUTOSTART  # PERSIST not kept
    again = Rig(storage=rig.storage)
    again.board.boot()
    assert again.board.streaming and again.board.settings.rate_hz == 250
    again.run(20_000)
    kinds = [name(f) for f in again.frames()]
    assert kinds[0] == "HELLO" and kinds.count("SAMPLE") in (4, 5)


def test_config_persist_storage_failure_applies_nothing(rig):
    rig.storage.fail_writes = True
    before = rig.board.settings.fields()
    seq, frames = rig.config(rate=250, flags=CFG_STREAM_CONTACTS | CFG_PERSIST)
    assert only_reply(frames, seq)[3] == (CMD_CONFIG, seq, NAK_STORAGE, NAK_DETAIL_NONE)
    assert rig.board.settings.fields() == before


def test_corrupt_settings_file_falls_back_to_defaults(rig):
    rig.config(rate=250, flags=CFG_PERSIST)
    data = bytearray(rig.storage.read(settings.FILE_NAME))
    data[6] ^= 0xFF
    rig.storage.files[settings.FILE_NAME] = bytes(data)
    again = Rig(storage=rig.storage)
    again.board.boot()
    assert again.board.settings.rate_hz == settings.DEFAULT_RATE_HZ


def test_start_stop_toggle_streaming_and_link_hook(rig):
    seq, frames = rig.command(CMD_START)
    assert name(only_reply(frames, seq)) == "ACK"
    assert rig.board.streaming and rig.link.streaming_on
    assert info(rig)["flags"] & CFG_STREAMING
    seq, frames = rig.command(CMD_START)  # idempotent
    assert name(only_reply(frames, seq)) == "ACK"
    seq, frames = rig.command(CMD_STOP)
    assert name(only_reply(frames, seq)) == "ACK"
    assert not rig.board.streaming and not rig.link.streaming_on
    rig.run(10_000)
    assert not [f for f in rig.frames() if name(f) in ("SAMPLE", "CONTACT")]


def test_tare_captures_the_mean_and_acks_when_done(rig):
    codes = (1000, -2000, 3000, 40, 50, -60)
    rig.set_codes(0, codes)
    seq, frames = rig.command(CMD_TARE, (0, 20), us=5000)
    assert not replies(frames, seq)  # 20 samples at 1 kHz take 20 ms
    rig.run(20_000)
    assert name(only_reply(rig.frames(), seq)) == "ACK"
    assert rig.board.cals[0].bias_counts() == [float(c) for c in codes]
    rig.config(rate=1000, flags=CFG_STREAM_SAMPLES)
    rig.command(CMD_START)
    rig.run(5000)
    samples = [f for f in rig.frames() if name(f) == "SAMPLE"]
    assert samples and all(f[3][2:] == (0, 0, 0, 0, 0, 0) for f in samples)


@pytest.mark.parametrize(
    "values, reason, detail",
    [((1, 10), NAK_OUT_OF_RANGE, 0), ((0, 10001), NAK_OUT_OF_RANGE, 1)],
)
def test_tare_refusals(rig, values, reason, detail):
    seq, frames = rig.command(CMD_TARE, values)
    assert only_reply(frames, seq)[3] == (CMD_TARE, seq, reason, detail)
    assert rig.board.tare_mask == 0


def test_tare_while_taring_and_on_a_faulted_sensor(rig):
    s1 = rig.send(CMD_TARE, (0, 0))  # 0: the default count
    s2 = rig.send(CMD_TARE, (0xFF, 10))
    rig.run(1000)
    frames = rig.frames()
    assert only_reply(frames, s2)[3] == (CMD_TARE, s2, NAK_BAD_STATE, NAK_DETAIL_NONE)
    rig.run(200_000)
    assert name(only_reply(rig.frames(), s1)) == "ACK"
    rig.buses[0].nack.add(0x40)
    rig.command(CMD_START)
    rig.run(3000)
    seq, frames = rig.command(CMD_TARE, (0, 10))
    assert only_reply(frames, seq)[3] == (CMD_TARE, seq, NAK_HARDWARE, 0)


def cal_values(sensor, cal_id, matrix):
    return (sensor, cal_id) + tuple(matrix)


def test_set_cal_stores_applies_and_reports_id(rig):
    m = [0.0] * 36
    for r in range(6):
        m[r * 6 + r] = 2e-6 if r < 3 else 1e-7
    identity = struct.pack("<36f", *calibration.identity())
    assert info(rig)["crc0"] == binascii.crc_hqx(identity, 0xFFFF)  # no file: the identity's
    seq, frames = rig.command(CMD_SET_CAL, cal_values(0, 4242, m))
    assert name(only_reply(frames, seq)) == "ACK"
    sent = struct.pack("<36f", *m)  # the bytes SET_CAL carried, hashed by another route
    assert (info(rig)["cal0"], info(rig)["crc0"]) == (4242, binascii.crc_hqx(sent, 0xFFFF))
    stored = calibration.load(rig.storage, 0)
    assert stored.cal_id == 4242
    assert struct.pack("<36f", *stored.coefficients()) == sent  # bit for bit, not approximately
    assert stored.crc == binascii.crc_hqx(sent, 0xFFFF)  # what the board reports after a reboot


@pytest.mark.parametrize("k", [0, 17, 35])
def test_set_cal_non_finite_coefficient_is_refused(rig, k):
    m = [0.0] * 36
    m[k] = float("nan") if k != 17 else float("inf")
    seq, frames = rig.command(CMD_SET_CAL, cal_values(0, 1, m), check=False)
    assert only_reply(frames, seq)[3] == (CMD_SET_CAL, seq, NAK_OUT_OF_RANGE, 2 + k)
    assert rig.board.cals[0].cal_id == 0 and rig.storage.read("cal0.bin") is None


def test_set_cal_bad_sensor_and_storage_failure(rig):
    seq, frames = rig.command(CMD_SET_CAL, cal_values(1, 1, [0.0] * 36))
    assert only_reply(frames, seq)[3] == (CMD_SET_CAL, seq, NAK_OUT_OF_RANGE, 0)
    rig.storage.fail_writes = True
    seq, frames = rig.command(CMD_SET_CAL, cal_values(0, 9, [1e-6] * 36))
    assert only_reply(frames, seq)[3] == (CMD_SET_CAL, seq, NAK_STORAGE, NAK_DETAIL_NONE)
    assert rig.board.cals[0].cal_id == 0


def raw_frame(body):
    crc = crc16(body)
    return cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\0"


def test_malformed_commands_get_reasons(rig):
    # a PING with a payload byte: bad length
    rig.link.put(raw_frame(struct.pack("<BBHI", PROTOCOL_VERSION, CMD_PING, 77, 0) + b"\x01"))
    # an unknown command type
    rig.link.put(raw_frame(struct.pack("<BBHI", PROTOCOL_VERSION, 0x7E, 78, 0)))
    # another protocol version
    rig.link.put(raw_frame(struct.pack("<BBHI", 9, CMD_PING, 79, 0)))
    # a device-to-host type sent to the device
    rig.link.put(raw_frame(struct.pack("<BBHBH", PROTOCOL_VERSION, 0x06, 80, 0, 0x40) + b"\0\0\0"))
    # a frame with a bad CRC: dropped, counted, not answered
    bad = bytearray(raw_frame(struct.pack("<BBHI", PROTOCOL_VERSION, CMD_PING, 81, 0)))
    bad[3] ^= 0x10
    rig.link.put(bytes(bad))
    rig.run(2000)
    frames = rig.frames()
    assert only_reply(frames, 77)[3] == (CMD_PING, 77, NAK_BAD_LENGTH, NAK_DETAIL_NONE)
    assert only_reply(frames, 78)[3] == (0x7E, 78, NAK_UNKNOWN_COMMAND, NAK_DETAIL_NONE)
    assert only_reply(frames, 79)[3] == (CMD_PING, 79, NAK_BAD_VERSION, NAK_DETAIL_NONE)
    assert only_reply(frames, 80)[3] == (0x06, 80, NAK_UNKNOWN_COMMAND, NAK_DETAIL_NONE)
    assert not replies(frames, 81)
    assert rig.board.rx_errors == 1


def test_every_command_is_answered_exactly_once(rig):
    cmds = [
        (CMD_PING, ()),
        (CMD_GET_INFO, ()),
        (CMD_CONFIG, (100, 10, 5, 1, 0)),
        (CMD_START, ()),
        (CMD_STOP, ()),
        (CMD_TARE, (0, 5)),
        (CMD_SET_CAL, cal_values(0, 3, [1e-6] * 36)),
    ]
    seqs = [rig.send(t, v) for t, v in cmds]
    rig.run(200_000)
    frames = rig.frames()
    for s in seqs:
        assert len(replies(frames, s)) == 1
