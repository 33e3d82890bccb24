"""Instructions per sample of the C core on ARMv6-M, counted in QEMU (issue 16, speed).

Run: ``.venv/bin/python bench/fw_c_qemu.py [--seconds 3]``.  The C core's micro:bit image
(``firmware/c/qemu``, ``arm-none-eabi-gcc -mcpu=cortex-m0plus -Os``) runs in
``qemu-system-arm -M microbit`` (a Cortex-M0: ARMv6-M, as the RP2040's M0+) with
``-icount shift=0``: one instruction is one nanosecond of virtual time, which the image
reads from the nRF51's TIMER1 at 16 MHz (62.5 instructions per tick) around 2,000 calls of
each stage and 400 whole polls (``bench.c``), on the press scene's sensor (1 kHz, SAMPLE and
CONTACT streams).  A whole poll includes the HAL's own instructions (the device channel that
stands in for the I2C peripheral: a semihosting call per transfer) but not the time an I2C
transfer takes on a real bus (576 bit-times per sample, docs/firmware.md).

Then the same image served on a pty as ``tactile emulate press --core qemu`` serves it, in
real time and ``--fast``, read by a host in the same process: samples per wall second, and
samples the board flagged late (its device channel to the Python ADC models is the cost).
"""

import argparse
import sys
import time

import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.qemu_core import QemuUnavailable, bench

NS_PER_TICK = 1e9 / 16e6  # TIMER1, prescaler 0
CLOCK_HZ = 125e6  # an RP2040's M0+
TARGET = 5000  # instructions per sample, whole poll, one sensor (issue 16)


def served(seconds, fast):
    """(samples, late samples, wall s) for ``seconds`` of the press scene's board time."""
    from tactile_sim.emulator.qemu_server import QemuServer

    server = QemuServer(EmulatedBoard(load_scene("press"), core="qemu"), realtime=not fast,
                        duration_s=seconds)  # fmt: skip
    decoder, n, late = StreamDecoder(), 0, 0
    t0 = time.monotonic()
    with server, serial.Serial(server.path, timeout=0.05) as port:
        while server.serving or port.in_waiting:
            data = port.read(1)
            for m in decoder.feed(data + port.read(port.in_waiting)):
                if m.type_name == "SAMPLE":
                    n += 1
                    late += bool(m.flags & C.FLAG_LATE)
        wall = time.monotonic() - t0
    return n, late, wall


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=3.0, help="board time served per run")
    args = ap.parse_args()
    emu = EmulatedBoard(load_scene("press"), core="qemu", boot_id=1)
    try:
        report = bench(emu)
    except QemuUnavailable as exc:
        sys.exit(f"fw_c_qemu: {exc}")
    loop, cal, gate, enc, reps, sampled, t_sampled, idle, t_idle, n = report
    per = lambda ticks: (ticks - loop) * NS_PER_TICK / reps  # noqa: E731  instructions
    rows = [
        ("calibrate: 6x6 fixed point, one sensor (`tc_cal_apply`)", per(cal)),
        ("gate: hysteresis + debounce (`tc_gate_update`)", per(gate)),
        ("encode: SAMPLE frame, pack + CRC-16 + COBS (`tc_encode`)", per(enc)),
        (f"whole `tc_board_poll` that takes a sample ({sampled} polls)",
         t_sampled * NS_PER_TICK / sampled),
    ]  # fmt: skip
    if idle:
        rows.append(
            (f"`tc_board_poll` with nothing due ({idle} polls)", t_idle * NS_PER_TICK / idle)
        )
    print(f"| stage ({n} sensor, 1 kHz, SAMPLE + CONTACT) | instructions | at 125 MHz, 1 kHz |")
    print("|---|---:|---:|")
    for label, instr in rows:
        print(f"| {label} | {instr:,.0f} | {instr * 1e3 / CLOCK_HZ:.2%} |")
    whole = rows[3][1]
    verdict = "met" if whole < TARGET else "missed"
    print(f"\nTarget: under {TARGET:,} instructions for the whole poll of one sensor: {verdict}.")
    print("\n| served on a pty (press, 1 kHz) | samples | late | wall s | samples/s |")
    print("|---|---:|---:|---:|---:|")
    for fast in (False, True):
        n, late, wall = served(args.seconds, fast)
        mode = f"{'--fast (-icount)' if fast else 'real time'}, {args.seconds:g} s of board time"
        print(f"| {mode} | {n} | {late} | {wall:.2f} | {n / wall:,.0f} |")


if __name__ == "__main__":
    main()
