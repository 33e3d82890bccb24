"""MicroPython entry: machine.I2C, USB CDC stdio, optional watchdog (Raspberry Pi Pico).

The only board file that imports ``machine``.  ``/main.py`` on the board is
``from tactile_fw.port_mpy import main`` / ``main()``.

Wiring (docs/firmware.md): I2C0 on GP4 (SDA) / GP5 (SCL), I2C1 on GP6 (SDA) /
GP7 (SCL), 1 MHz (Fast-mode Plus; keep the bus short, 2.2 kOhm pull-ups).
Sensor 0 on I2C0 at 0x40-0x45, sensor 1 on I2C1 at 0x40-0x45, sensors 2 and
3 at 0x46-0x4B on I2C0 and I2C1.
"""

import os
import select
import sys
import time

import machine
import micropython

from tactile_fw.board import Board, boot_id_from
from tactile_fw.frontend import make_sensor
from tactile_fw.storage import DirStorage

I2C_PINS = ((0, 4, 5), (1, 6, 7))  # (controller, SDA GPIO, SCL GPIO)


class UsbLink:
    """USB CDC stdio without blocking: poll before every read and write.

    MicroPython's stdio gives no DTR signal, so ``opened`` never fires here:
    HELLO goes out at boot, and the host asks GET_INFO after opening.
    """

    def __init__(self):
        self._in = sys.stdin.buffer
        self._out = sys.stdout.buffer
        self._pin = select.poll()
        self._pin.register(sys.stdin, select.POLLIN)
        self._pout = select.poll()
        self._pout.register(sys.stdout, select.POLLOUT)
        self._one = bytearray(1)

    @staticmethod
    def _ready(poller):
        for _ in poller.ipoll(0):  # ipoll: no list allocated per call
            return True
        return False

    def readinto(self, buf):
        n = 0
        one = self._one
        while n < len(buf) and self._ready(self._pin):
            if not self._in.readinto(one):
                break
            buf[n] = one[0]
            n += 1
        return n

    def write(self, mv):
        if not self._ready(self._pout):
            return None
        return self._out.write(mv)

    def opened(self):
        return False

    def streaming(self, on):
        # Frames contain 0x03; Ctrl-C must not interrupt while streaming.
        micropython.kbd_intr(-1 if on else 3)


def make_sensors(n_sensors, freq):
    buses = [
        machine.I2C(c, sda=machine.Pin(sda), scl=machine.Pin(scl), freq=freq)
        for c, sda, scl in I2C_PINS
    ]
    return [make_sensor(buses[i % 2], i // 2, bus_key=i % 2, bus_hz=freq) for i in range(n_sensors)]


def boot_entropy():
    """Bytes that differ per power-up: the RP2040's ring-oscillator RNG behind os.urandom,
    or on a port without it the chip's id and the free-running CPU tick counter."""
    try:
        return os.urandom(8)
    except AttributeError:
        t = time.ticks_cpu()
        return machine.unique_id() + bytes((t & 0xFF, (t >> 8) & 0xFF, (t >> 16) & 0xFF))


def main(n_sensors=1, freq=1000000, wdt_ms=0):
    sensors = make_sensors(n_sensors, freq)
    board = Board(sensors, UsbLink(), time, DirStorage(""), boot_id=boot_id_from(boot_entropy()))
    wdt = machine.WDT(timeout=wdt_ms) if wdt_ms else None
    board.boot()
    try:
        board.run(feed=wdt.feed if wdt else None, sleep_us=time.sleep_us)
    finally:
        micropython.kbd_intr(3)
