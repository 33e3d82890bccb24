"""The emulated Raspberry Pi Pico (``--core rp2040``): stock MicroPython on rp2040js.

What a user's Pico does before and after ``tactile flash``: a REPL on its USB serial port,
a flash that keeps what was written to it across restarts, and, once flashed, the firmware
answering on the same port with its sensors read over the chip's own I2C controllers.
"""

import time

import serial
from pico_target import serve

from tactile.board_client import BoardClient


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
        client = BoardClient(serial.Serial(server.path, timeout=0.05), server.path)
        try:
            client.handshake(timeout=10.0)
            info = client.get_info(timeout=10.0)  # (HELLO goes out before the sensors start)
        finally:
            client.close()
        requests = server.chip.requests
    assert info.n_sensors == 1 and info.sensor_model.rstrip(b"\0") == b"FT6/ADS122C04x6"
    assert requests >= 12  # RESET, CONFIG0/1 written and read back, START: six converters
