"""MicroPython entry: machine.I2C, USB CDC stdio, optional watchdog (Raspberry Pi Pico).

The only board file that imports ``machine``.  ``/main.py`` on the board is
``from tactile_fw.port_mpy import main`` / ``main()``.

Two boards run here, the same protocol and the same bytes: the C core as a native module
(``tactile_native.mpy`` in ``/lib``, built from ``firmware/c`` by
``tactile_fw_tools.natmod``), used when it is there and built from this firmware, and the
Python ``Board`` otherwise (or when ``main(core="python")`` asks for it).  Both get the same
buses, USB link rules, storage, boot id and board id (the flash chip's unique id,
``machine.unique_id()``), and the same loop (``run``).

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

from tactile_fw.identity import FW_VERSION, board_id_from, boot_id_from
from tactile_fw.storage import DirStorage
from tactile_protocol.constants import PROTOCOL_VERSION

I2C_PINS = ((0, 4, 5), (1, 6, 7))  # (controller, SDA GPIO, SCL GPIO)
WATCHDOG_CTRL = 0x40058000  # RP2040 datasheet §4.7.6: machine.WDT cannot be stopped
WATCHDOG_ENABLE = 1 << 30
TIMERAWL = 0x40054028  # RP2040 datasheet §4.6.5: the 1 MHz timer's low word, read unlatched
NATIVE_API = 2  # the contract with firmware/c/natmod/tactile_native.c (2: board_id)


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


def make_buses(freq):
    return [
        machine.I2C(c, sda=machine.Pin(sda), scl=machine.Pin(scl), freq=freq)
        for c, sda, scl in I2C_PINS
    ]


def boot_entropy():
    """Bytes that differ per power-up: the RP2040's ring-oscillator RNG behind os.urandom,
    or on a port without it the chip's id and the free-running CPU tick counter."""
    try:
        return os.urandom(8)
    except AttributeError:
        t = time.ticks_cpu()
        return machine.unique_id() + bytes((t & 0xFF, (t >> 8) & 0xFF, (t >> 16) & 0xFF))


def native_module():
    """``tactile_native`` if it loads here and was built from this firmware, else None.

    Its clock is the RP2040's timer register, so another chip never takes it; an .mpy made
    for another MicroPython fails to import (ValueError) and the Python board runs."""
    if "RP2040" not in sys.implementation._machine:
        return None
    try:
        import tactile_native
    except (ImportError, ValueError):
        return None
    mine = (NATIVE_API, FW_VERSION, PROTOCOL_VERSION)
    if (tactile_native.API, tactile_native.FW_VERSION, tactile_native.PROTOCOL_VERSION) != mine:
        return None
    return tactile_native


# What a sample costs this chip besides its converters: the CPU time per sensor at 125 MHz
# of each board (bench/fw_pico_rate.py, docs/firmware.md), and the bus time, which the CPU
# spends waiting too (machine.I2C blocks, and the two controllers take turns).
CPU_US_PER_SENSOR = {"native": 240, "python": 5900}
SPARE_PERCENT = 10  # of the CPU a rate leaves for USB, commands and the collector


def chip_ceiling(n_sensors, freq, core):
    """The highest rate (Hz, down to 10 Hz) at which ``core`` keeps ``SPARE_PERCENT`` of
    this chip's CPU with ``n_sensors`` on I2C at ``freq``, and the converters keep up."""
    from tactile_fw.frontend import BITS_PER_CONVERTER, N_GAUGES

    bus_us = N_GAUGES * BITS_PER_CONVERTER * 1000000 // freq
    cpu_us = CPU_US_PER_SENSOR[core] * 125000000 // machine.freq()
    rate = (100 - SPARE_PERCENT) * 10000 // (n_sensors * (bus_us + cpu_us))
    return min(rate, CONVERTER_SPS) // 10 * 10


CONVERTER_SPS = 2000  # the ADS122C04 in turbo mode, one conversion per gauge a sample


def make_board(n_sensors=1, freq=1000000, core="auto", max_rate_hz=0):
    """The board for this Pico: ``core`` "native" (the C core), "python" (``Board``), or
    "auto": native when ``native_module()`` has it.  Neither has booted yet.  Its ceiling
    (HELLO/INFO ``max_rate_hz``, CONFIG's limit) is ``chip_ceiling``'s; ``max_rate_hz``
    overrides it (benches only)."""
    buses = make_buses(freq)
    storage = DirStorage("")
    boot_id = boot_id_from(boot_entropy())
    board_id = board_id_from(machine.unique_id())  # the RP2040's: its flash chip's 64-bit id
    native = None if core == "python" else native_module()
    if native is not None:
        micropython.kbd_intr(-1)  # (as UsbLink does: frames hold Ctrl-C bytes)
        layout = [(i % 2, i // 2, freq) for i in range(n_sensors)]
        usb = (sys.stdin.buffer, sys.stdout.buffer)
        ceiling = max_rate_hz or chip_ceiling(n_sensors, freq, "native")
        return native.Board(
            buses, layout, usb, TIMERAWL, storage, boot_id, ceiling, BreakIn, board_id
        )
    if core == "native":
        raise ImportError("tactile_native is not in /lib or not built from this firmware")
    from tactile_fw.board import Board
    from tactile_fw.frontend import make_sensor

    sensors = [
        make_sensor(buses[i % 2], i // 2, bus_key=i % 2, bus_hz=freq) for i in range(n_sensors)
    ]
    ceiling = max_rate_hz or chip_ceiling(n_sensors, freq, "python")
    return Board(
        sensors, UsbLink(), time, storage, max_rate_hz=ceiling, boot_id=boot_id, board_id=board_id
    )


def run(board, feed=None, sleep_us=time.sleep_us):
    """Poll forever, sleeping until the next sample is due; the loop survives any exception
    (``last_error`` = its errno, else 0xFF) and feeds the watchdog each turn."""
    while True:
        try:
            board.poll()
            d = board.idle_us()
            if d > 200:  # (long sleeps may end late: wake early, then wait out the rest)
                sleep_us(d - 100)
            elif d > 0:
                sleep_us(d)  # (a busy-wait: on time, and no poll spent on waiting)
        except Exception as exc:  # the loop never dies
            args = getattr(exc, "args", ())
            board.last_error = args[0] & 0xFF if args and isinstance(args[0], int) else 0xFF
        if feed is not None:
            feed()


def main(n_sensors=1, freq=1000000, wdt_ms=0, core="auto"):
    board = make_board(n_sensors, freq, core)
    wdt = machine.WDT(timeout=wdt_ms) if wdt_ms else None
    try:
        board.boot()
        run(board, wdt.feed if wdt else None)
    finally:
        micropython.kbd_intr(3)  # the REPL's Ctrl-C again
        if wdt is not None:  # nothing feeds it now: off, or it would reset the REPL's user
            machine.mem32[WATCHDOG_CTRL] &= ~WATCHDOG_ENABLE
