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
WATCHDOG_CTRL = 0x40058000  # RP2040 datasheet §4.7.6: machine.WDT cannot be stopped
WATCHDOG_ENABLE = 1 << 30


# MicroPython's REPL ends a program at Ctrl-C (0x03), and every command frame holds a 0x03
# (the protocol version, sent verbatim by COBS): Ctrl-C is off while the firmware runs. A host
# breaks in with CR, Ctrl-C, CR as the first bytes of a frame (mpremote's "\r\x03" then
# "\r\x01"): no frame starts so (its third byte is the type, and 0x0D is no command).
BREAK_IN = b"\r\x03\r"


class BreakIn(KeyboardInterrupt):
    """A host asked for the REPL (``BREAK_IN``): the firmware stops, the REPL takes over."""


class UsbLink:
    """USB CDC stdio without blocking: poll before every read and write.

    MicroPython's stdio gives no DTR signal, so ``opened`` never fires here:
    HELLO goes out at boot, and the host asks GET_INFO after opening.  Reads go byte by
    byte, so a break-in stops reading at its last byte and leaves the rest (mpremote's
    Ctrl-A, for the raw REPL) to the REPL.
    """

    def __init__(self):
        self._in = sys.stdin.buffer
        self._out = sys.stdout.buffer
        self._pin = select.poll()
        self._pin.register(sys.stdin, select.POLLIN)
        self._pout = select.poll()
        self._pout.register(sys.stdout, select.POLLOUT)
        self._one = bytearray(1)
        self._at = 0  # bytes since the last frame delimiter (counted up to 3)
        self._match = 0  # of those, how many followed BREAK_IN
        micropython.kbd_intr(-1)

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
            b = one[0]
            buf[n] = b
            n += 1
            if b == 0:
                self._at = self._match = 0
            elif self._at < 3:
                if self._match == self._at and b == BREAK_IN[self._at]:
                    self._match += 1
                    if self._match == 3:
                        raise BreakIn()
                self._at += 1
        return n

    def write(self, mv):
        if not self._ready(self._pout):
            return None
        return self._out.write(mv)

    def opened(self):
        return False

    def streaming(self, on):
        pass  # Ctrl-C stays off either way (above)


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
    try:
        board.boot()
        board.run(feed=wdt.feed if wdt else None, sleep_us=time.sleep_us)
    finally:
        micropython.kbd_intr(3)  # the REPL's Ctrl-C again
        if wdt is not None:  # nothing feeds it now: off, or it would reset the REPL's user
            machine.mem32[WATCHDOG_CTRL] &= ~WATCHDOG_ENABLE
