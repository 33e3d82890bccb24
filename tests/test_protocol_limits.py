"""Field limits (PROTOCOL.md §4, ``tactile_protocol.limits``): a device that lies is named.

A table of lies, one row per rule, through the host decoder; and the firmware's own
checks agree with the protocol's table, so the board never sends what the host refuses.
"""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tactile.board.stream_decoder import StreamDecoder
from tactile_fw import calibration, settings
from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_protocol.limits import violation
from tactile_protocol.messages import BY_NAME

HELLO = dict(
    fw_major=1,
    fw_minor=0,
    fw_patch=0,
    protocol_version=C.PROTOCOL_VERSION,
    sensor_model=b"FT6",
    n_sensors=2,
    max_rate_hz=1730,
    cal_id_0=7,
    cal_id_1=0,
    cal_id_2=0,
    cal_id_3=0,
    rate_hz=1000,
    enter_threshold=1_390_000,
    exit_threshold=1_112_000,
    debounce=3,
    flags=C.CFG_STREAM_CONTACTS | C.CFG_STREAMING,
)
BASE = {
    "HELLO": HELLO,
    "INFO": HELLO,
    "SAMPLE": dict(sensor=0, flags=0xFF, fx=1, fy=2, fz=3, tx=4, ty=5, tz=6),
    "CONTACT": dict(sensor=1, phase=2, contact_id=9, flags=0, fx=0, fy=0, fz=0, tx=0, ty=0, tz=0),
    "STATUS": dict(
        faults=0xBF,
        sensor=0xFF,
        last_error=5,
        i2c_errors=1,
        drdy_timeouts=2,
        saturations=3,
        overruns=4,
        tx_dropped=5,
        samples=6,
    ),
    "ACK": dict(cmd_type=C.CMD_CONFIG, cmd_seq=3),
    "NAK": dict(cmd_type=0x06, cmd_seq=3, reason=C.NAK_STORAGE, detail=0xFF),
    "CONFIG": dict(rate_hz=1, enter_threshold=0, exit_threshold=0, debounce=255, flags=0x1F),
    "TARE": dict(sensor=0xFF, n_samples=C.MAX_TARE_SAMPLES),
    "SET_CAL": dict(sensor=1, cal_id=1, **{f"c{r}{c}": 1.5 for r in range(6) for c in range(6)}),
}

NOT_FINITE = "is not finite (protocol allows finite float32 values)"
# (message, changed fields, the line the host shows); None: still valid.
LIES = [
    ("HELLO", dict(n_sensors=5), "n_sensors = 5 (protocol allows 1..4)"),
    ("HELLO", dict(n_sensors=255), "n_sensors = 255 (protocol allows 1..4)"),
    ("INFO", dict(n_sensors=0), "n_sensors = 0 (protocol allows 1..4)"),
    (
        "HELLO",
        dict(protocol_version=9),
        f"protocol_version = 9 (protocol allows {C.PROTOCOL_VERSION})",
    ),
    ("HELLO", dict(max_rate_hz=0, rate_hz=0), "max_rate_hz = 0 (protocol allows 1..65535)"),
    ("INFO", dict(rate_hz=1731), "rate_hz = 1731 (protocol allows 1..max_rate_hz = 1730)"),
    ("INFO", dict(rate_hz=1730), None),
    ("INFO", dict(enter_threshold=-1), "enter_threshold = -1 (protocol allows 0..2147483647)"),
    (
        "HELLO",
        dict(exit_threshold=1_390_001),
        "exit_threshold = 1390001 (protocol allows 0..enter_threshold = 1390000)",
    ),
    ("HELLO", dict(debounce=0), "debounce = 0 (protocol allows 1..255)"),
    ("HELLO", dict(flags=C.CFG_PERSIST), "flags = 0x10 (protocol allows bits 0x2f)"),
    ("HELLO", dict(flags=0x80), "flags = 0x80 (protocol allows bits 0x2f)"),
    ("HELLO", dict(sensor_model=b"\x1b[2J\n\xff"), None),  # text: escaped when shown
    ("SAMPLE", dict(sensor=4), "sensor = 4 (protocol allows 0..3)"),
    ("CONTACT", dict(phase=3), "phase = 3 (protocol allows 0..2)"),
    ("STATUS", dict(sensor=4), "sensor = 4 (protocol allows 0..3 or 255 for all)"),
    ("STATUS", dict(faults=0x40), "faults = 0x40 (protocol allows bits 0xbf)"),
    ("ACK", dict(cmd_type=0x06), "cmd_type = 6 (protocol allows 64..127)"),
    ("NAK", dict(reason=0), "reason = 0 (protocol allows 1..8)"),
    ("NAK", dict(reason=9), "reason = 9 (protocol allows 1..8)"),
    ("CONFIG", dict(flags=0x20), "flags = 0x20 (protocol allows bits 0x1f)"),
    ("CONFIG", dict(rate_hz=0), "rate_hz = 0 (protocol allows 1..65535)"),
    ("TARE", dict(n_samples=10_001), "n_samples = 10001 (protocol allows 0..10000)"),
    ("TARE", dict(sensor=4), "sensor = 4 (protocol allows 0..3 or 255 for all)"),
    ("SET_CAL", dict(c05=float("nan")), "c05 " + NOT_FINITE),
    ("SET_CAL", dict(c50=float("-inf")), "c50 " + NOT_FINITE),
]


def _values(name, changes):
    fields, codes = BY_NAME[name][4], BY_NAME[name][5]
    base = {**BASE[name], **changes}
    return tuple(base.get(f, b"" if c.endswith("s") else 0) for f, c in zip(fields, codes))


def _frame(name, changes, seq=0):
    return bytes(FrameEncoder(seq).encode(BY_NAME[name][0], 0, _values(name, changes), False))


def test_every_limited_message_has_a_valid_base():
    for name in BASE:
        assert violation(name, _values(name, {})) is None, name
        (msg,) = StreamDecoder().feed(_frame(name, {}))
        assert msg.type_name == name


@pytest.mark.parametrize("name, changes, line", LIES, ids=[f"{n}-{c}" for n, c, _ in LIES])
def test_a_lie_is_delivered_as_invalid_naming_the_field(name, changes, line):
    decoder = StreamDecoder()
    (msg,) = decoder.feed(_frame(name, changes, seq=5))
    c = decoder.counters
    if line is None:
        assert msg.type_name == name and c.invalid == 0
        return
    assert (msg.type_name, msg.message, msg.error, msg.seq) == ("INVALID", name, line, 5)
    assert (c.invalid, c.frames, c.last_invalid) == (1, 0, f"{name}: {line}")
    assert msg.to_dict() == {
        "type": "INVALID",
        "seq": 5,
        "timestamp_us": 0,
        "message": name,
        "error": line,
    }


def test_sensor_indices_follow_the_announced_count_and_refusals_are_not_loss():
    decoder = StreamDecoder()
    stream = _frame("SAMPLE", dict(sensor=3), seq=0)  # before any HELLO: 0..3
    stream += _frame("HELLO", dict(n_sensors=1), seq=1)
    stream += _frame("SAMPLE", dict(sensor=1), seq=2)
    stream += _frame("STATUS", dict(sensor=0xFF), seq=3)
    stream += _frame("HELLO", dict(n_sensors=9), seq=4)  # refused: the count stays 1
    stream += _frame("CONTACT", dict(sensor=1), seq=5)
    got = decoder.feed(stream)
    assert [m.type_name for m in got] == ["SAMPLE", "HELLO", "INVALID", "STATUS", "INVALID"] + [
        "INVALID"
    ]
    assert got[2].error == "sensor = 1 (the device announced 1 sensor: 0..0)"
    assert decoder.counters.lost_frames == 0 and decoder.counters.invalid == 3


_CONFIG_FIELD = st.integers(-(2**31), 2**31 - 1)


@given(
    st.integers(0, 0xFFFF),
    _CONFIG_FIELD,
    _CONFIG_FIELD,
    st.integers(0, 0xFF),
    st.integers(0, 0xFF),
)
def test_the_firmware_refuses_exactly_the_configs_the_protocol_refuses(rate, enter, exit_, d, f):
    board = settings.check(rate, enter, exit_, d, f, 0xFFFF)  # the field ceiling
    assert (board == -1) == (violation("CONFIG", (rate, enter, exit_, d, f)) is None)
    if board >= 0:
        field = BY_NAME["CONFIG"][4][board]
        assert violation("CONFIG", (rate, enter, exit_, d, f)).startswith(field + " ")


@given(st.lists(st.floats(width=32), min_size=36, max_size=36))
def test_the_firmware_refuses_exactly_the_calibrations_the_protocol_refuses(coeffs):
    bad = calibration.bad_coefficient(coeffs)
    why = violation("SET_CAL", (0, 1, *coeffs))
    assert (bad == -1) == (why is None)
    if why is not None:
        assert why.startswith(BY_NAME["SET_CAL"][4][2 + bad] + " ")
