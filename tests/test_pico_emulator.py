"""The emulated Raspberry Pi Pico (``--core rp2040``): stock MicroPython on rp2040js.

What a user's Pico does before and after ``tactile flash``: a REPL on its USB serial port,
a flash that keeps what was written to it across restarts, and, once flashed, the firmware
answering on the same port with its sensors read over the chip's own I2C controllers.
"""

import os
import time

import pytest
import serial
from pico_target import serve, wait_booted

from tactile.board.client import BoardClient
from tactile_sim.emulator.pico_core import flash_board_id

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


def _read_until(port, marker, seconds):
    out, end = b"", time.monotonic() + seconds
    while marker not in out and time.monotonic() < end:
        out += port.read(4096)
    return out


def test_a_new_board_is_stock_micropython_at_its_repl_within_seconds(tmp_path):
    with serve(flash=tmp_path / "new.flash") as server:
        start = time.monotonic()
        with serial.Serial(server.path, timeout=0.05) as port:
            port.write(b"\r\n")
            out = _read_until(port, b">>> ", 5.0)
            waited = time.monotonic() - start
            port.write(b"import sys; print(sys.implementation._machine)\r\n")
            out += _read_until(port, b"RP2040\r\n", 5.0)
    assert b">>> " in out and waited <= 5.0
    assert b"Raspberry Pi Pico with RP2040" in out


def test_what_the_chip_writes_to_flash_is_there_after_a_restart(tmp_path):
    flash = tmp_path / "board.flash"
    with serve(flash=flash) as server, serial.Serial(server.path, timeout=0.05) as port:
        port.write(b"\r\nf = open('kept.txt', 'w'); f.write('still here'); f.close()\r\n")
        _read_until(port, b"10\r\n>>> ", 10.0)
    with serve(flash=flash) as server, serial.Serial(server.path, timeout=0.05) as port:
        port.write(b"\r\nprint(open('kept.txt').read())\r\n")
        out = _read_until(port, b"still here\r\n", 10.0)
    assert b"still here\r\n" in out


def test_a_flashed_board_answers_with_its_sensor_read_over_i2c(pico_flashed):
    with serve(flash=pico_flashed) as server:
        wait_booted(server)
        client = BoardClient(serial.Serial(server.path, timeout=0.05), server.path)
        try:
            client.handshake(timeout=10.0)
            info = client.get_info(timeout=10.0)  # (HELLO goes out before the sensors start)
        finally:
            client.close()
        requests = server.chip.requests
    assert info.n_sensors == 1 and info.sensor_model.rstrip(b"\0") == b"FT6/ADS122C04x6"
    assert requests >= 12  # RESET, CONFIG0/1 written and read back, START: six converters
    # machine.unique_id(): its flash chip's id, one per emulated Pico (rp2040js's own: 0)
    assert info.board_id == flash_board_id(pico_flashed) != bytes(8)


def _until_it_asks(chip, seconds=60.0):
    """Read the chip's messages (type, 2-byte length, payload) until it asks an I2C question
    ('A' or 'R'): it then waits for the answer, which nobody gives here."""
    import select

    buf, end = b"", time.monotonic() + seconds
    while time.monotonic() < end:
        if select.select([chip.fd], [], [], 0.1)[0]:
            buf += os.read(chip.fd, 65536)
        while len(buf) >= 3 and len(buf) >= 3 + int.from_bytes(buf[1:3], "little"):
            if buf[:1] in (b"A", b"R"):
                return
            buf = buf[3 + int.from_bytes(buf[1:3], "little") :]
    raise AssertionError("the chip asked nothing")


def test_a_chip_waiting_for_an_answer_ends_when_closed_not_killed(pico_flashed):
    """A server stopped while its chip waits for an I2C answer (what every run's end meets):
    closing the pipes ends node there, at once; the order to quit alone was never read, and
    each close waited 5 s for the kill."""
    server = serve(flash=pico_flashed)
    try:
        chip = server.launch()
        _until_it_asks(chip)
    finally:
        server.close()
    assert chip.proc.returncode == 0  # it left by itself (a kill is -9)


def _emulate(tmp_path, *args, env=None):
    import os
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "tactile.cli.main", "emulate", "press", "--core", "rp2040",
           "--flash", str(tmp_path / "board.flash"), "--duration", "0.01", *args]  # fmt: skip
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, **(env or {})))  # fmt: skip


def test_tactile_emulate_core_rp2040_prints_its_pty_and_stops_at_its_duration(tmp_path):
    r = _emulate(tmp_path)  # --duration 0.01: of the chip's time
    assert r.returncode == 0 and r.stdout.startswith("/dev/pts/"), r.stderr
    assert "on the rp2040 core" in r.stderr and (tmp_path / "board.flash").stat().st_size == 2**21


def test_what_the_emulated_pico_lacks_is_named_in_one_line(tmp_path):
    import shutil

    no_node, no_npm = tmp_path / "bin1", tmp_path / "bin2"
    for folder in (no_node, no_npm):
        folder.mkdir()
    (no_npm / "node").symlink_to(shutil.which("node"))
    empty_cache = str(tmp_path / "cache")  # rp2040js not installed there yet
    cases = [
        ({"PATH": str(no_node)}, "node not found: install Node.js"),
        ({"TACTILE_RP2_DIR": str(tmp_path)}, "no bootrom-b1.bin and micropython-rpi_pico.uf2"),
        ({"XDG_CACHE_HOME": empty_cache, "PATH": str(no_npm)}, "npm not found"),
    ]
    for env, said in cases:
        r = _emulate(tmp_path, env=env)
        assert r.returncode == 2, (env, r.stderr)
        assert said in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert "Traceback" not in r.stderr


def test_a_flash_file_is_one_boards_and_must_be_a_flash(tmp_path):
    from tactile_sim.emulator.pico_core import lock_flash

    (tmp_path / "board.flash").write_bytes(b"not a flash")
    r = _emulate(tmp_path)
    assert r.returncode == 2 and "not an emulated Pico's flash" in r.stderr, r.stderr
    (tmp_path / "board.flash").unlink()
    held = lock_flash(tmp_path / "board.flash")  # another emulator has it
    try:
        r = _emulate(tmp_path)
    finally:
        import os

        os.close(held)
    assert r.returncode == 4 and "in use by another emulated Pico" in r.stderr, r.stderr


@pytest.mark.slow
def test_the_same_forces_give_the_same_codes_as_on_the_other_cores(pico_flashed, tmp_path):
    """One model behind every core: a steady, noiseless load read by the firmware on the
    emulated Pico (its I2C answered by pico_core) and by the in-process Python core gives the
    same integers, once both hold the same calibration."""
    import re

    from board_target import read_for

    from tactile.board.serial_port import open_port
    from tactile_protocol import constants as C
    from tactile_sim.emulator import load_scene
    from tactile_sim.emulator.device import EmulatedBoard

    text = load_scene("press").path.read_text()
    text = re.sub(r"noise_force_N = .*", "noise_force_N = [0.0, 0.0, 0.0]", text)
    load = "0.8, -0.6, 2.5, 0.02, -0.01, 0.005"  # N, N*m from t = 0 to 9 s
    text = re.sub(r"keyframes = \[.*?\n\]", f"keyframes = [[0.0, {load}], [9.0, {load}]]", text,
                  flags=re.S)  # fmt: skip
    scene = tmp_path / "steady.toml"
    scene.write_text(text)
    model = EmulatedBoard(load_scene(scene)).models[0]

    def samples(client):
        client.configure(200, 1.39, 1.112, 3, C.CFG_STREAM_SAMPLES)
        ack = client.start()
        got = read_for(
            client, 20.0, until=lambda m: len([s for s in m if s.type_name == "SAMPLE"]) > 5
        )
        return {
            (s.fx, s.fy, s.fz, s.tx, s.ty, s.tz)
            for s in got
            if s.type_name == "SAMPLE" and s.seq > ack.seq
        }

    reference = BoardClient(open_port(f"sim://{scene}"), "sim")
    try:
        reference.handshake(2.0)
        python_core = samples(reference)
    finally:
        reference.close()
    with serve(scene, flash=pico_flashed) as server:
        wait_booted(server)
        client = BoardClient(serial.Serial(server.path, timeout=0.05), server.path)
        try:
            client.handshake(10.0)
            client.set_calibration(0, 7, model.calibration_coefficients(), timeout=10.0)
            on_the_chip = samples(client)
        finally:
            client.close()
    assert len(python_core) == 1 and on_the_chip == python_core  # every sample, one wrench
    assert abs(next(iter(on_the_chip))[0] - 0.8e6) < 0.01e6  # uN: fx of the scene's load
