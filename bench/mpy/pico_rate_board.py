"""Runs on the (emulated) Pico: how fast a board built by port_mpy keeps up, in the chip's time.

bench/fw_pico_rate.py prepends its parameters (``PARAMS``) and reads the result line.  Each
run writes settings.bin (the rate, SAMPLE and CONTACT streams, a gate at 0 so that every
sample is in contact: a SAMPLE and a CONTACT frame per sensor, the heaviest steady load,
autostart), builds the board as main() does (port_mpy.make_board: machine.I2C at 1 MHz, USB
stdio, the flash), boots it and runs port_mpy.run's loop for RUN_US after a warm-up, timing
each poll with the chip's ticks_us:

- work: the polls that had something due (idle_us() == 0 before them: a sample to take or
  a read pending), their whole time, bus transfers included (machine.I2C blocks); the
  polls that only wait out the last 100 us before a deadline are not work;
- a rate is sustained when no sample was late (overruns 0) and all were taken.
"""

import gc
import time

import micropython

from tactile_fw import port_mpy
from tactile_fw.settings import Settings
from tactile_fw.storage import DirStorage

CORE, N_SENSORS = PARAMS["CORE"], PARAMS["N_SENSORS"]  # noqa: F821 (prepended)
TARGET_HZ, RUN_US = PARAMS["TARGET_HZ"], PARAMS["RUN_US"]  # noqa: F821
CONVERTER_HZ = 2000  # the ADS122C04 in turbo mode: a fresh result every 500 us
FLAGS = 0x01 | 0x02 | 0x08  # CFG_STREAM_SAMPLES | CFG_STREAM_CONTACTS | CFG_AUTOSTART
WARM_US = 20000


def counter(board, name):
    part = {"overruns": "sched", "tx_dropped": "tx"}.get(name)
    if part and hasattr(board, part):  # the Python board keeps these in its parts
        return getattr(getattr(board, part), "dropped" if name == "tx_dropped" else name)
    return getattr(board, name)


def run(rate, run_us):
    """(samples, overruns, tx_dropped, work_us, work_polls, polls, elapsed_us) at ``rate``."""
    Settings(rate, 0, 0, 1, FLAGS).save(DirStorage(""))
    board = port_mpy.make_board(N_SENSORS, 1000000, CORE, 60000)
    board.boot()
    gc.collect()
    ticks_us, ticks_diff, sleep_us = time.ticks_us, time.ticks_diff, time.sleep_us
    t0 = ticks_us()
    counted = False
    work = polls = work_polls = 0
    while True:
        now = ticks_us()
        if not counted and ticks_diff(now, t0) >= WARM_US:
            counted, t0 = True, now
            s0, o0, d0 = board.samples, counter(board, "overruns"), counter(board, "tx_dropped")
            work = polls = work_polls = 0
        elif counted and ticks_diff(now, t0) >= run_us:
            break
        due = board.idle_us() == 0
        a = ticks_us()
        board.poll()
        b = ticks_us()
        polls += 1
        if due:
            work += ticks_diff(b, a)
            work_polls += 1
        d = board.idle_us()
        if d > 200:
            sleep_us(d - 100)
    elapsed = ticks_diff(ticks_us(), t0)
    out = (
        board.samples - s0,
        counter(board, "overruns") - o0,
        counter(board, "tx_dropped") - d0,
        work,
        work_polls,
        polls,
        elapsed,
    )
    del board
    gc.collect()
    return out


def sustains(rate):
    r = run(rate, RUN_US)
    expected = rate * r[6] // 1000000 * N_SENSORS
    return r[1] == 0 and r[0] >= expected - N_SENSORS, r


def tens(x):
    return max(10, int(x) // 10 * 10)


def main():
    target = run(TARGET_HZ, RUN_US)
    per_sample = target[3] * N_SENSORS / max(1, target[0])  # work a board's sample costs
    best = 0
    rate = min(CONVERTER_HZ, tens(0.97 * 1000000 / per_sample))
    tried = []
    while rate >= 10:  # down from the prediction (work, converters) until one is sustained
        ok, r = sustains(rate)
        tried.append((rate, ok, r[1]))
        if ok:
            best = rate
            break
        rate = tens(rate * 0.95) if rate > 10 else 0
    while best:  # then up while sustained
        rate = max(best + 10, tens(best * 1.04))
        if rate <= best:
            break
        ok, r = sustains(rate)
        tried.append((rate, ok, r[1]))
        if not ok:
            break
        best = rate
    micropython.kbd_intr(3)
    print("\x00BENCH", repr({"target": target, "max_hz": best, "tried": tried}))


main()
