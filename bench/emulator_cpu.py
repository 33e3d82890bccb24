"""Emulator cost: samples per CPU-second for each firmware core and sensor count, against
what real time needs (sensors x rate), the emulator alone (no pty, no host).

Run: ``.venv/bin/python bench/emulator_cpu.py [--seconds 2] [--repeat 3] [--rate 1000 ...]``.

Each row runs ``--seconds`` of scene time with every sensor pressed and released, and
counts the samples the firmware took per CPU-second of this process (``time.process_time``:
the transducer, ADC and I2C models, the firmware and the encoder).  ``x real time`` is
that rate over sensors x rate: below 1 the board cannot keep real time on one core, and
in real time it then falls behind and flags late samples (docs/emulator.md).  The cores
take turns, so their ratio is measured under the same load; the best of ``--repeat``.
Core ``c`` answers the converters' reads in C (``emulator/adc_bank``); ``c-callbacks`` is
the same core with a Python callback per I2C transaction (``cores.C_I2C``), as before.
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_args import positive_int  # noqa: E402

from tactile_sim.emulator import cores  # noqa: E402
from tactile_sim.emulator.device import EmulatedBoard  # noqa: E402
from tactile_sim.emulator.scene import Scene  # noqa: E402

KEYS = [[0.0, 0, 0, 0, 0, 0, 0], [0.05, 3.2, 2.4, -1, 0, 0, 0], [0.1, 0, 0, 0, 0, 0, 0]]


def scene(sensors, rate_hz):
    data = {
        "scene": {"name": f"bench-{sensors}x{rate_hz}"},
        "board": {"sensors": sensors, "rate_hz": rate_hz, "max_rate_hz": max(rate_hz, 1000)},
        "sensor": {"bias_counts": 0.0},
        "motion": {"kind": "press", "keyframes": KEYS, "repeat": True},
    }
    return Scene(f"<bench {sensors} x {rate_hz} Hz>", data)


def run(sensors, rate_hz, seconds, core):
    """(samples taken, CPU s) for ``seconds`` of scene time."""
    cores.C_I2C = "callbacks" if core == "c-callbacks" else "bank"
    board = EmulatedBoard(scene(sensors, rate_hz), core=core.split("-")[0])
    board.run_until(100_000)  # (boot, first conversions)
    board.read_host()
    start, taken = time.process_time(), board.board.samples
    t, end = board.t_us, board.t_us + int(seconds * 1e6)
    while t < end:
        t += 20_000
        board.run_until(t)
        board.read_host()
    return board.board.samples - taken, time.process_time() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="scene seconds a row")
    ap.add_argument("--rate", type=positive_int, action="append", help="Hz (default 1000, 5000)")
    ap.add_argument("--repeat", type=positive_int, default=3, help="runs a row (best kept)")
    args = ap.parse_args()
    use = ["python"]
    try:
        cores.c_library()
        use += ["c-callbacks", "c"]
    except cores.CoreUnavailable as exc:
        print(f"(no C core: {exc})")
    print("| sensors | rate Hz | core | samples / CPU s | needed / s | x real time |")
    print("|---|---|---|---|---|---|")
    for rate in args.rate or [1000, 5000]:
        for sensors in (1, 2, 4):
            best = dict.fromkeys(use, 0.0)
            for _ in range(args.repeat):  # the cores take turns
                for core in use:
                    n, cpu = run(sensors, rate, args.seconds, core)
                    best[core] = max(best[core], n / cpu if cpu > 0 else float("inf"))
            for core in use:
                per = best[core]
                need = sensors * rate
                print(f"| {sensors} | {rate} | {core} | {per:,.0f} | {need:,} | {per / need:.2f} |",
                      flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
