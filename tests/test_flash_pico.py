"""``tactile flash`` on emulated boards, as a user runs it: the emulator's python core (the
tactile protocol on a pty, no MicroPython behind it) ends in one line; an emulated Pico,
new or already streaming from boot, is flashed and then answers ``tactile info``.

Bounds are generous (the emulated Pico runs at about 0.2x a real one, on a shared
machine); what is asserted is what the board and the host report."""

import time

import numpy as np
import pytest
import serial
from board_target import BoardTarget
from pico_target import serve

from tactile import load_recording
from tactile.board import flashing, handover, raw_repl
from tactile.board.client import BoardClient
from tactile_protocol import constants as C

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


def test_the_python_cores_pty_is_no_micropython_board_and_says_so_in_one_line(cli):
    with BoardTarget("python").serve("press") as path:
        start = time.monotonic()
        code, out, err = cli("flash", "--port", path)
        took = time.monotonic() - start
    assert (code, out) == (4, "")
    assert err == (
        f"tactile flash: error: found the tactile firmware speaking its protocol on {path} "
        "(firmware 0.1.0, no MicroPython REPL behind it)\n"
    )
    assert took < 30.0  # about 3 s: frames for FIRMWARE_S after the first, nothing else


def _plant(path, files):
    """Write ``files`` ({board path: bytes}) through the raw REPL, as an earlier flash
    would have left them."""
    session = raw_repl.Session(path)
    try:
        session.serial.timeout = handover.READ_TIMEOUT_S
        handover.break_in(session.serial, path)
        session.serial.timeout = raw_repl.READ_TIMEOUT_S
        session.enter(10.0)
        session.exec(flashing.MKDIRS.format(dirs=["/lib", "/lib/tactile_fw"]), 10.0, "mkdir")
        for where, data in files.items():
            session.write_file(where, data, 10.0)
    finally:
        session.close()


@pytest.mark.slow
def test_a_new_pico_is_flashed_and_answers(tmp_path, cli):
    with serve(flash=tmp_path / "new.flash") as pico:
        _plant(pico.path, {"/lib/tactile_fw/retired.py": b"raise ImportError('retired')\n"})
        code, out, err = cli("flash", "--port", pico.path, "--sensors", "1")
        assert (code, err) == (0, ""), err
        assert out.startswith(
            f"flashed {len(flashing.board_files()) + 1} files as .mpy v6 to {pico.path}"
            " (1 stale removed) and reset it;"
            f" it answers: tactile firmware 0.1.0 (protocol {C.PROTOCOL_VERSION}), 1 sensor"
            " FT6/ADS122C04x6,"
        )
        code, out, err = cli("info", "--port", pico.path, "--wait", "10")
        assert (code, err) == (0, "") and out.startswith(
            f"firmware      0.1.0  (protocol {C.PROTOCOL_VERSION})"
        )
        # then it samples at 1 kHz (the native module flash copied), every frame whole
        # (--wait: an emulated chip on a loaded machine runs slower than a real one)
        code, _, err = cli("config", "--port", pico.path, "--rate", "1000", "--streams",
                           "samples", "--wait", "10")  # fmt: skip
        assert code == 0, err
        code, out, err = cli("record", "--port", pico.path, "--duration", "3", "--no-tare",
                             "--wait", "10", "-o", tmp_path / "run", "--quiet")  # fmt: skip
    assert code == 0 and "lost 0 frames, 0 CRC errors, 0 gaps" in out, (out, err)
    rec = load_recording(tmp_path / "run")
    t = rec.board_time_s  # the board's clock
    per_s = (len(t) - 1) / (t[-1] - t[0])
    assert len(t) > 300 and abs(per_s - 1000) < 1 and not rec.is_contact.any()  # per board s
    assert not np.any(rec.flags & C.FLAG_LATE)


@pytest.mark.slow
def test_a_pico_that_streams_from_boot_is_stopped_flashed_and_streams_again(pico_flashed, cli):
    with serve(flash=pico_flashed) as pico:
        client = BoardClient(serial.Serial(pico.path, timeout=0.05), pico.path)
        try:
            info = client.handshake(timeout=15.0)
            flags = C.CFG_STREAM_SAMPLES | C.CFG_AUTOSTART | C.CFG_PERSIST
            client.configure(100, 1.39, 1.112, 3, flags, timeout=5.0)
        finally:
            client.close()
    assert info.fw_major == 0
    with serve(flash=pico_flashed) as pico:  # a power cycle: it streams from boot
        with serial.Serial(pico.path, timeout=0.05) as port:
            client = BoardClient(port, pico.path)
            got, end = [], time.monotonic() + 15.0
            while time.monotonic() < end and len(got) < 3:
                got += [m for m in client.read() if m.type_code == C.MSG_SAMPLE]
        assert len(got) >= 3  # streaming, with no command sent
        code, out, err = cli("flash", "--port", pico.path)
        assert (code, err) == (0, ""), err
        assert "it answers: tactile firmware 0.1.0" in out and ", 100 Hz (ceiling" in out
        code, out, err = cli("info", "--port", pico.path, "--wait", "10")
    assert code == 0, err
    assert "streams       samples (autostart); streaming" in out
