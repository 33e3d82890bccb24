"""How fast the emulated Raspberry Pi Pico runs, against the wall clock, while it streams.

Flashes the firmware onto an emulated Pico (``tactile flash``, the native module included),
then for each rate streams SAMPLE frames to this script for ``--seconds`` of wall time in
fast mode and counts: the chip's seconds per wall second, samples per wall second, and
samples the board flagged late (its own verdict, in its own clock).  Each rate runs with the
emulator's busy-wait skipping on and off (``TACTILE_PICO_SPIN=0``), side by side, so the
gain and the cost in timing are in one table: the largest gap between consecutive samples'
stamps and a deadline is the skip's whole effect on the board's clock.

    .venv/bin/python bench/pico_speed.py [--seconds 6] [--rates 250,500,1000]

About a minute a rate on a 2-core machine.
"""

import argparse
import contextlib
import os
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def chip(flash, spin):
    """An emulated Pico in fast mode on a pty, in a thread (as tests/pico_target.serve)."""
    from tactile_sim.emulator.servers import serve

    os.environ["TACTILE_PICO_SPIN"] = "1" if spin else "0"
    with serve("press", core="rp2040", flash=flash, realtime=False) as server:
        yield server


def booted(server, timeout_s=60.0):
    end = time.monotonic() + timeout_s
    while server.chip.requests == 0 and time.monotonic() < end:
        time.sleep(0.02)


def stream(server, rate, seconds):
    """(chip s per wall s, samples per wall s, late samples, largest |step - period| in us)."""
    import serial

    from tactile.board.client import BoardClient
    from tactile_protocol import constants as C

    client = BoardClient(serial.Serial(server.path, timeout=0.05), server.path)
    try:
        client.handshake(10.0)
        client.configure(rate, 1.39, 1.112, 3, C.CFG_STREAM_SAMPLES, timeout=5.0)
        client.start(timeout=5.0)
        got, start, chip0 = [], time.monotonic(), server.chip.t_us
        while time.monotonic() - start < seconds:
            got += [m for m in client.read() if m.type_code == C.MSG_SAMPLE]
        wall, chip_s = time.monotonic() - start, (server.chip.t_us - chip0) / 1e6
        client.stop(timeout=5.0)
    finally:
        client.close()
    got = got[rate // 10 :]  # (the first 0.1 s: commands handled beside the samples)
    period = 1e6 / rate
    worst = max(abs((b.timestamp_us - a.timestamp_us) - period) for a, b in zip(got, got[1:]))
    late = sum(1 for m in got if m.flags & C.FLAG_LATE)
    return chip_s / wall, len(got) / wall, late, worst


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=6.0, help="wall seconds per run")
    p.add_argument("--rates", default="250,500,1000", help="Hz, comma list")
    args = p.parse_args(argv)
    sys.path.insert(0, str(ROOT / "tests"))
    from tactile.board import flashing

    rates = [int(r) for r in args.rates.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        flash = pathlib.Path(tmp) / "pico.flash"
        with chip(flash, True) as server:
            flashing.flash(server.path, n_sensors=1)
        print("| rate (Hz) | busy-wait skip | chip s / wall s | samples / wall s | late | "
              "largest stamp error (us) |")  # fmt: skip
        print("|---:|---|---:|---:|---:|---:|")
        for rate in rates:
            for spin in (True, False):
                with chip(flash, spin) as server:
                    booted(server)
                    speed, per_s, late, worst = stream(server, rate, args.seconds)
                print(f"| {rate} | {'on' if spin else 'off'} | {speed:.2f} | {per_s:,.0f} | "
                      f"{late} | {worst:.0f} |")  # fmt: skip


if __name__ == "__main__":
    main()
