"""A device that lies (issue 12): escape codes, non-finite numbers, out-of-range fields.

Regression tests per defect, then hypothesis campaigns: HELLO/INFO payloads with any
field values (valid framing, lying content) through the host decoder and the
``info``, ``decode`` and ``record`` paths give valid output or one line with exit 4 -
never a traceback, never a raw control character on stdout or stderr.
"""

import contextlib
import io
import json
import math
import tempfile
from pathlib import Path

import pytest
from conftest import FUZZ_SCALE
from hypothesis import event, given, settings
from hypothesis import strategies as st
from lying_device import CODES, FIELDS, GOOD_INFO, LyingPort, frame, info_values, lying_ports

from tactile.board.stream_decoder import StreamDecoder
from tactile.cli.main import main
from tactile.output.text import printable
from tactile_protocol import constants as C
from tactile_protocol.limits import violation

ESC_MODEL = b"\x1b[31mRED\x1b[0m\nX"
info_with = info_values


def run(*args):
    """``tactile ARGS`` in-process: (exit code, stdout, stderr); a traceback fails the test."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def assert_terminal_safe(*texts):
    for text in texts:
        bad = [ch for ch in text if not (ch.isprintable() or ch == "\n")]
        assert not bad, f"raw control characters {bad!r} in {text!r}"
        assert "Traceback" not in text


def assert_one_line_error(code, out, err, exit_code=4):
    assert code == exit_code and out == ""
    assert err.count("\n") == 1 and err.startswith("tactile "), err
    assert_terminal_safe(err)


# -- escape codes --------------------------------------------------------------------------


def test_printable_escapes_what_a_terminal_would_act_on():
    assert printable("FT6/ADS122C04x6") == "FT6/ADS122C04x6"
    assert printable("\x1b[2J\n\r\t\x7f\x00\u2028\x9b") == r"\x1b[2J\n\r\t\x7f\x00\u2028\x9b"
    assert printable("µ-sensor ü") == "µ-sensor ü"  # printable text is left alone


def test_info_escapes_escape_codes_in_the_sensor_model():
    with lying_ports(lambda: LyingPort(info_with(sensor_model=ESC_MODEL))):
        code, out, err = run("info", "--port", "lie")
        assert code == 0 and err == ""
        assert_terminal_safe(out)
        assert r"sensor        \x1b[31mRED\x1b[0m\nX x 1" in out
        assert len(out.splitlines()) == 6  # the newline did not forge a line
        code, out, _ = run("info", "--port", "lie", "--json")
    assert code == 0 and json.loads(out)["sensor_model"] == ESC_MODEL.decode()
    assert "\x1b" not in out


def test_decode_escapes_device_strings(tmp_path):
    path = tmp_path / "cap.bin"
    path.write_bytes(frame(C.MSG_HELLO, info_with(sensor_model=ESC_MODEL)))
    code, out, err = run("decode", path)
    assert code == 0 and err == ""
    assert_terminal_safe(out)
    assert r"sensor_model=\x1b[31mRED\x1b[0m\nX n_sensors=1" in out.splitlines()[0]


# -- non-finite numbers: one rule for text and JSON ------------------------------------------


def test_decode_non_finite_calibration_is_refused_alike_in_text_and_json(tmp_path):
    path = tmp_path / "cap.bin"
    coeffs = [1.0] * 36
    coeffs[0], coeffs[7] = math.nan, math.inf
    path.write_bytes(frame(C.CMD_SET_CAL, (0, 5, *coeffs)))
    code, text, _ = run("decode", path)
    assert code == 0
    line = "INVALID  SET_CAL seq=0 timestamp_us=0: c00 is not finite"
    assert text.splitlines()[0].startswith(line)
    code, js, _ = run("decode", path, "--json")
    first = json.loads(js.splitlines()[0])
    assert first["type"] == "INVALID" and first["error"].startswith("c00 is not finite")
    for out in (text, js):
        assert not {"nan", "inf", "NaN", "Infinity"} & set(out.replace(":", " ").split())


def test_text_output_writes_non_finite_numbers_as_null_like_json():
    from tactile.cli.cmd_board import _text
    from tactile.output.text import dumps

    d = {"type": "X", "a": math.nan, "b": -math.inf, "c": 1.5, "s": "ok\x1b"}
    assert _text(d) == r"X        a=null b=null c=1.5 s=ok\x1b"
    assert dumps(d) == '{"type":"X","a":null,"b":null,"c":1.5,"s":"ok\\u001b"}'


# -- out-of-range fields ----------------------------------------------------------------------


@pytest.mark.parametrize("n", [0, 5, 255])
def test_info_refuses_a_hello_with_an_impossible_sensor_count(n):
    with lying_ports(lambda: LyingPort(info_with(n_sensors=n))):
        code, out, err = run("info", "--port", "lie")
    assert_one_line_error(code, out, err)
    assert f"lie: device sent an invalid HELLO: n_sensors = {n} (protocol allows 1..4)" in err


def test_info_refuses_an_invalid_info_after_a_valid_hello():
    with lying_ports(lambda: LyingPort(GOOD_INFO, info=info_with(rate_hz=1731))):
        code, out, err = run("info", "--port", "lie")
    assert_one_line_error(code, out, err)
    assert "invalid INFO: rate_hz = 1731 (protocol allows 1..max_rate_hz = 1730)" in err


class NakLiar(LyingPort):
    """Answers CONFIG with a NAK whose reason the protocol does not have."""

    def write(self, data):
        for m in StreamDecoder().feed(bytes(data)):
            if m.type_code == C.CMD_CONFIG:
                self.out += self._frame(C.MSG_NAK, (C.CMD_CONFIG, m.seq, 99, 0xFF))
                return len(data)
        return super().write(data)


def test_config_names_a_lying_nak():
    with lying_ports(NakLiar):
        code, out, err = run("config", "--port", "lie", "--rate", "500")
    assert_one_line_error(code, out, err)
    assert "device sent an invalid NAK: reason = 99 (protocol allows 1..8)" in err


@pytest.mark.parametrize("n", [5, 255])
def test_record_with_a_lying_hello_exits_4_and_still_writes_meta(tmp_path, n):
    out_dir = tmp_path / "run"
    with lying_ports(lambda: LyingPort(info_with(n_sensors=n))):
        code, out, err = run("record", "--port", "lie", "--duration", "5", "-o", out_dir, "--quiet")
    assert_one_line_error(code, out, err)
    assert f"invalid HELLO: n_sensors = {n}" in err
    meta = json.loads((out_dir / "meta.json").read_text())
    capture = (out_dir / "capture.bin").read_bytes()
    assert meta["ended"] == "error" and meta["device"] is None
    assert meta["bytes"] == len(capture) > 0  # what the device sent is kept
    assert meta["decoder"]["invalid"] == 1
    assert meta["decoder"]["last_invalid"].startswith(f"HELLO: n_sensors = {n} ")


def test_record_keeps_recording_through_lying_frames_and_counts_them(tmp_path):
    sample = lambda sensor, fx: (C.MSG_SAMPLE, (sensor, 0, fx, 0, 0, 0, 0, 0))  # noqa: E731
    stream = [sample(0, 1), sample(3, 2), (C.MSG_CONTACT, (0, 7, 1, 0, 0, 0, 0, 0, 0, 0))]
    stream += [sample(0, 3), (C.MSG_STATUS, (0x40, 0, 0, 0, 0, 0, 0, 0, 0)), sample(0, 4)]
    out_dir = tmp_path / "run"
    with lying_ports(lambda: LyingPort(stream=stream)):
        code, out, err = run("record", "--port", "lie", "--duration", "0.3", "-o", out_dir,
                             "--quiet")  # fmt: skip
    assert code == 0 and err == "", err
    assert_terminal_safe(out)
    assert ", 3 invalid frames refused -> " in out
    rows = (out_dir / "frames.csv").read_text().splitlines()[2:]  # below units, header
    assert [r.split(",")[9] for r in rows] == ["0.000001", "0.000003", "0.000004"]  # fx_N
    device = [json.loads(line) for line in (out_dir / "device.jsonl").read_text().splitlines()]
    errors = [d["error"] for d in device if d["type"] == "INVALID"]
    assert errors == [
        "sensor = 3 (the device announced 1 sensor: 0..0)",
        "phase = 7 (protocol allows 0..2)",
        "faults = 0x40 (protocol allows bits 0xbf)",
    ]
    meta = json.loads((out_dir / "meta.json").read_text())
    assert meta["decoder"]["invalid"] == 3 and meta["decoder"]["lost_frames"] == 0
    assert meta["samples"] == 3


def test_decode_counts_and_reports_a_lying_hello(tmp_path):
    path = tmp_path / "cap.bin"
    data = frame(C.MSG_HELLO, info_with(n_sensors=5), seq=0)
    data += frame(C.MSG_SAMPLE, (0, 0, 1, 2, 3, 4, 5, 6), seq=1)
    path.write_bytes(data)
    code, out, err = run("decode", path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == ("INVALID  HELLO seq=0 timestamp_us=0: n_sensors = 5 (protocol allows 1..4)")
    assert lines[1].startswith("SAMPLE   seq=1")
    assert " invalid=1 " in lines[-1] and " lost_frames=0 " in lines[-1]
    code, out, _ = run("decode", path, "--json")
    summary = json.loads(out.splitlines()[-1])["summary"]
    assert summary["invalid"] == 1 and summary["last_invalid"].startswith("HELLO: n_sensors = 5")


# -- property-based: any HELLO/INFO content, valid framing -------------------------------------

_BY_CODE = {
    "B": st.integers(0, 0xFF),
    "H": st.integers(0, 0xFFFF),
    "I": st.integers(0, 0xFFFFFFFF),
    "i": st.integers(-(2**31), 2**31 - 1),
    "16s": st.binary(max_size=16),
    "8s": st.binary(max_size=8),
}
_TYPES = {f: _BY_CODE[c] for f, c in zip(FIELDS, CODES)}  # any value the field's type holds


@st.composite
def payloads(draw):
    """A HELLO/INFO payload: a valid one with some fields lying, or every field arbitrary."""
    if draw(st.booleans()):
        return tuple(draw(_TYPES[f]) for f in FIELDS)
    liars = draw(st.lists(st.sampled_from(FIELDS), max_size=3, unique=True))
    return info_with(**{f: draw(_TYPES[f]) for f in liars})


def _bad(values):
    why = violation("HELLO", values)
    event("lie" if why else "valid")  # both kinds are drawn: --hypothesis-show-statistics
    return why


@settings(max_examples=200 * FUZZ_SCALE)
@given(payloads(), payloads())
def test_any_hello_and_info_through_the_decoder(hello, info):
    """Valid content comes out as it went in, a lie as INVALID naming a field; seq counts."""
    data = frame(C.MSG_HELLO, hello, seq=0) + frame(C.MSG_INFO, info, seq=1)
    data += frame(C.MSG_SAMPLE, (0, 0, 1, 2, 3, 4, 5, 6), seq=2)
    decoder = StreamDecoder()
    got = decoder.feed(data)
    for msg, values, name in ((got[0], hello, "HELLO"), (got[1], info, "INFO")):
        why = _bad(values)
        if why is None:
            assert msg.type_name == name and tuple(msg)[2:6] == values[:4]
        else:
            assert (msg.type_name, msg.message, msg.error) == ("INVALID", name, why)
    assert got[2].type_name == "SAMPLE" and decoder.counters.lost_frames == 0


@settings(max_examples=100 * FUZZ_SCALE)
@given(payloads(), payloads())
def test_any_hello_and_info_through_info(hello, info):
    with lying_ports(lambda: LyingPort(hello, info=info)):
        code, out, err = run("info", "--port", "lie", "--wait", "0.5")
    assert_terminal_safe(out, err)
    lie = _bad(hello) or _bad(info)
    if lie is None:
        assert code == 0 and err == "" and out.startswith("firmware ")
        assert len(out.splitlines()) == 6  # (one line per field group: no field forges one)
    else:
        assert_one_line_error(code, out, err)
        assert lie in err


@settings(max_examples=100 * FUZZ_SCALE)
@given(payloads(), st.booleans())
def test_any_hello_through_decode(hello, as_json):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cap.bin"
        path.write_bytes(frame(C.MSG_HELLO, hello))
        code, out, err = run("decode", path, *(["--json"] if as_json else []))
    assert code == 0 and err == ""
    assert_terminal_safe(out)
    first = json.loads(out.splitlines()[0]) if as_json else out.splitlines()[0]
    kind = first["type"] if as_json else first.split()[0]
    assert kind == ("HELLO" if _bad(hello) is None else "INVALID")


@settings(max_examples=25 * FUZZ_SCALE)
@given(payloads())
def test_any_hello_through_record_keeps_everything(hello):
    with tempfile.TemporaryDirectory() as tmp, lying_ports(lambda: LyingPort(hello)):
        out_dir = Path(tmp) / "run"
        code, out, err = run("record", "--port", "lie", "--duration", "0.05", "--no-tare",
                             "-o", out_dir, "--quiet")  # fmt: skip
        meta = json.loads((out_dir / "meta.json").read_text())
        capture = (out_dir / "capture.bin").read_bytes()
    assert_terminal_safe(out, err)
    assert meta["bytes"] == len(capture) > 0
    if _bad(hello) is None:
        assert code == 0 and meta["device"]["n_sensors"] == hello[FIELDS.index("n_sensors")]
    else:
        assert_one_line_error(code, out, err)
        assert meta["ended"] == "error" and meta["decoder"]["invalid"] >= 1


class _SilentAfterHello(LyingPort):
    """A firmware hung after its HELLO and setup: no frame, no reply to PING."""

    def write(self, data):
        if any(m.type_code == C.CMD_PING for m in StreamDecoder(check_limits=False).feed(data)):
            return len(data)
        return super().write(data)


def test_record_gives_up_on_a_board_silent_after_hello_with_exit_4(tmp_path, monkeypatch):
    import tactile.recording.session as session

    monkeypatch.setattr(session, "SILENT_S", 1.0)
    out_dir = tmp_path / "run"
    with lying_ports(_SilentAfterHello):
        code, out, err = run("record", "--port", "lie", "--duration", "30", "-o", out_dir,
                             "--no-tare", "--quiet")  # fmt: skip
    assert_one_line_error(code, out, err, exit_code=4)
    assert "lie: the board said nothing for 1 s, not even to PING" in err
    meta = json.loads((out_dir / "meta.json").read_text())
    assert meta["ended"] == "board silent" and meta["samples"] == 0
    assert meta["bytes"] == len((out_dir / "capture.bin").read_bytes()) > 0  # its HELLO kept
