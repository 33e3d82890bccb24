"""Per-sample cost of the firmware's read -> calibrate -> gate -> encode under CPython.

CPython is a proxy for the board (MicroPython on an RP2040 is one to two
orders of magnitude slower; not measured here).  The bus is a null
``machine.I2C`` stand-in that answers at once, so "read" is the driver's own
overhead, not I2C time; the I2C time is computed from the bit budget.

    .venv/bin/python bench/fw_sample_cost.py

prints Markdown tables: cost per stage, and the sample-rate ceiling each
constraint implies.
"""

import platform
import time

from tactile_fw import frontend
from tactile_fw.ads122c04 import CMD_RDATA, DRDY, rreg
from tactile_fw.board import Board
from tactile_fw.calibration import Calibration
from tactile_fw.gate import ContactGate
from tactile_fw.link import TxRing
from tactile_fw.storage import MemoryStorage
from tactile_fw.timing import ManualClock
from tactile_protocol.constants import (
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    MSG_SAMPLE,
)
from tactile_protocol.framing import FrameEncoder

N = 20_000
REPEATS = 5


class NullBus:
    """Answers every transfer at once: DRDY always set, a fixed code."""

    def __init__(self):
        self.regs = [0, 0, 0, 0]

    def readfrom_mem_into(self, addr, mem, buf, addrsize=8):
        if mem == CMD_RDATA:
            buf[0], buf[1], buf[2] = 0x12, 0x34, 0x56
        elif mem == rreg(2):
            buf[0] = DRDY
        else:
            buf[0] = self.regs[(mem >> 2) & 3]

    def writeto_mem(self, addr, mem, buf, addrsize=8):
        self.regs[(mem >> 2) & 3] = buf[0]

    def writeto(self, addr, buf, stop=True):
        return len(buf) + 1


class Discard:
    def readinto(self, buf):
        return None

    def write(self, mv):
        return len(mv)

    def opened(self):
        return False


def per_call_us(fn, n=N):
    best = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best.append((time.perf_counter() - t0) / n * 1e6)
    return min(best)  # the least-disturbed run (timeit convention; the machine is shared)


def stages():
    sensor = frontend.make_sensor(NullBus(), 0)
    sensor.init()
    cal = Calibration([1e-7 * (1 + (k % 7)) for k in range(36)], 1)
    ft = [0] * 6
    g = ContactGate(1_000_000, 500_000, 3)
    enc = FrameEncoder()
    tx = TxRing(Discard())
    vals = [0, 0x40, 1, 2, 3, 4, 5, 6]
    rows = [
        ("read: 6 x (DRDY + RDATA) through the driver", lambda: sensor.poll()),
        ("calibrate: 6x6 matrix, bias, round, clamp", lambda: cal.apply(sensor.counts, ft)),
        ("gate: magnitude vs enter/exit, debounce", lambda: g.update(ft[0], ft[1], ft[2])),
        (
            "encode: SAMPLE frame (pack, CRC, COBS)",
            lambda: enc.encode(MSG_SAMPLE, 123456, vals, False),
        ),
        (
            "encode + copy into the transmit ring",
            lambda: tx.send(enc.encode(MSG_SAMPLE, 1, vals, False)),
        ),
    ]
    return [(name, per_call_us(fn)) for name, fn in rows]


def whole_poll(flags):
    """Board.poll() with one sample due per call: the loop as the board runs it."""
    clock = ManualClock(0)
    sensors = [frontend.make_sensor(NullBus(), 0)]
    b = Board(sensors, Discard(), clock, MemoryStorage())
    b.boot()
    b.settings.flags = flags
    b.start_streaming()
    period = b.sched.period_us

    def step():
        clock.t_us += period
        b.poll()

    return per_call_us(step)


def main():
    print(
        f"CPython {platform.python_version()} on {platform.machine()}, "
        f"best of {REPEATS} x {N} calls\n"
    )
    print("| stage | us per sample |")
    print("|---|---:|")
    total = 0.0
    for name, us in stages():
        total += us if not name.startswith("encode +") else 0
        print(f"| {name} | {us:.2f} |")
    print(f"| **sum read..encode** | **{total:.2f}** |")
    samples_only = whole_poll(CFG_STREAM_SAMPLES)
    both = whole_poll(CFG_STREAM_SAMPLES | CFG_STREAM_CONTACTS)
    print(f"| whole `Board.poll()`, SAMPLE stream | {samples_only:.2f} |")
    print(f"| whole `Board.poll()`, SAMPLE + CONTACT streams | {both:.2f} |")
    print()
    bus_us = frontend.N_GAUGES * frontend.BITS_PER_CONVERTER  # at 1 MHz: 1 bit = 1 us
    print("| constraint (one sensor) | time per sample | ceiling |")
    print("|---|---:|---:|")
    print("| ADS122C04 data rate, turbo mode, 2000 SPS | 500 us | 2000 Hz |")
    print(f"| I2C at 1 MHz: 6 x (39 + 57) bit-times | {bus_us} us | {1e6 / bus_us:.0f} Hz |")
    print(f"| I2C at 400 kHz | {bus_us * 2.5:.0f} us | {4e5 / bus_us:.0f} Hz |")
    print(f"| CPython CPU, whole poll (this machine) | {both:.1f} us | {1e6 / both:.0f} Hz |")
    print("| firmware ceiling (CONFIG refuses above), one sensor per 1 MHz bus | | 1730 Hz |")
    print("| two sensors sharing a 1 MHz bus | | 860 Hz |")


if __name__ == "__main__":
    main()
