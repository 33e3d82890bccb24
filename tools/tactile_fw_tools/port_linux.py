"""Linux-controller entry (CPython): smbus2 for the ADCs, a tty to the host.

Not copied to MicroPython boards.  Run as::

    python -m tactile_fw_tools.port_linux --tty /dev/ttyGS0 --i2c 1 --sensors 1

``SMBusI2C`` gives smbus2 the ``machine.I2C`` method names the driver calls;
a command byte followed by a repeated-start read is one ``i2c_rdwr``.  The board id
(HELLO/INFO ``board_id``) is ``machine_board_id()``: derived from the machine's
``/etc/machine-id`` (hashed, as systemd asks of ids shown to others).
"""

import argparse
import hashlib
import os
import sys
import termios
import time
import tty

from tactile_fw.board import Board
from tactile_fw.frontend import make_sensor
from tactile_fw.identity import NO_BOARD_ID, boot_id_from
from tactile_fw.storage import DirStorage
from tactile_fw.timing import TICKS_HALF, TICKS_MAX


def machine_board_id(path="/etc/machine-id"):
    """8 bytes that name this controller for its life: SHA-256 of its machine id and this
    firmware's name; ``NO_BOARD_ID`` when the file cannot be read."""
    try:
        with open(path, "rb") as fh:
            machine_id = fh.read(64).strip()
    except OSError:
        return NO_BOARD_ID
    if not machine_id:
        return NO_BOARD_ID
    return hashlib.sha256(b"tactile board id\0" + machine_id).digest()[:8]


class SMBusI2C:
    def __init__(self, bus_number, smbus=None):
        if smbus is None:
            from smbus2 import SMBus

            smbus = SMBus(bus_number)
        from smbus2 import i2c_msg

        self.bus = smbus
        self.msg = i2c_msg

    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        w = self.msg.write(addr, [memaddr])
        r = self.msg.read(addr, len(buf))
        self.bus.i2c_rdwr(w, r)
        buf[:] = bytes(r)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        self.bus.i2c_rdwr(self.msg.write(addr, bytes((memaddr,)) + bytes(buf)))

    def readfrom_into(self, addr, buf, stop=True):
        r = self.msg.read(addr, len(buf))
        self.bus.i2c_rdwr(r)
        buf[:] = bytes(r)

    def writeto(self, addr, buf, stop=True):
        self.bus.i2c_rdwr(self.msg.write(addr, bytes(buf)))
        return len(buf) + 1


class TtyLink:
    """A raw, non-blocking tty (USB gadget serial, UART, pty)."""

    def __init__(self, path):
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        if os.isatty(self.fd):
            tty.setraw(self.fd, termios.TCSANOW)

    def readinto(self, buf):
        try:
            data = os.read(self.fd, len(buf))
        except (BlockingIOError, InterruptedError):
            return None
        buf[: len(data)] = data
        return len(data)

    def write(self, mv):
        try:
            return os.write(self.fd, mv)
        except (BlockingIOError, InterruptedError):
            return None

    def opened(self):
        return False


class MonotonicClock:
    """MicroPython's tick functions over ``time.monotonic_ns``."""

    def ticks_us(self):
        return (time.monotonic_ns() // 1000) & TICKS_MAX

    def ticks_diff(self, a, b):
        return ((a - b + TICKS_HALF) & TICKS_MAX) - TICKS_HALF

    def ticks_add(self, a, d):
        return (a + d) & TICKS_MAX

    def sleep_us(self, d):
        time.sleep(d / 1e6)


def main(argv=None):
    p = argparse.ArgumentParser(
        prog="tactile_fw_tools.port_linux", description=__doc__.split("\n")[0]
    )
    p.add_argument("--tty", required=True, help="serial device towards the host")
    p.add_argument("--i2c", type=int, action="append", help="I2C bus number (repeat)")
    p.add_argument("--sensors", type=int, default=1)
    p.add_argument("--bus-hz", type=int, default=1000000)
    p.add_argument("--storage", default=".", help="directory for settings and calibration")
    a = p.parse_args(argv)
    try:
        buses = [SMBusI2C(n) for n in (a.i2c or [1])]
        link = TtyLink(a.tty)
    except OSError as exc:  # no /dev/i2c-N (i2c-dev not loaded, wrong bus), no tty, no access
        where = exc.filename or a.tty
        p.exit(
            4,
            f"{p.prog}: error: {where}: {exc.strerror} (is the i2c-dev module loaded?"
            " is the bus number right? may this user open it?)\n",
        )
    sensors = [
        make_sensor(buses[i % len(buses)], i // len(buses), i % len(buses), a.bus_hz)
        for i in range(a.sensors)
    ]
    clock = MonotonicClock()
    boot_id = boot_id_from(os.urandom(8))
    board = Board(
        sensors, link, clock, DirStorage(a.storage), boot_id=boot_id, board_id=machine_board_id()
    )
    board.boot()
    board.run(sleep_us=clock.sleep_us)


if __name__ == "__main__":
    sys.exit(main())
