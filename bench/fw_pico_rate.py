"""The firmware's sampling rate on the emulated Raspberry Pi Pico, both boards, in chip time.

Flashes the firmware onto an emulated Pico (``tactile flash``, as a user does), then runs
``bench/mpy/pico_rate_board.py`` on it over the raw REPL for each board (the Python ``Board``
and the C core in ``tactile_native``), one and two sensors (one per I2C controller), with
the emulator charging each I2C byte its bit time at the controller's SCL rate (1 MHz) and
again without bus time.  Times are the chip's own ``time.ticks_us`` (125 MHz), so the
emulator's speed does not enter; its USB does not either (pico_chip.mjs answers the chip's
USB OUT buffers only when the host has bytes).  The board streams over the chip's USB to
this script, which reads everything.

Per case: the work per sample (a poll that takes one sample of every sensor, bus included),
the CPU share left at the target rate (1 kHz for one sensor, 500 Hz for two: 1 - work /
elapsed) and the highest rate sustained (no late sample, every sample taken; searched down
from the work's prediction or the converters' 2 kSPS, then up in 4 % steps, 10 Hz
resolution).  Beside the bus-free run: the bus time the bytes of a sample take, 576
bit-times per sensor at 1 MHz (docs/firmware.md, "The sample-rate ceiling").

    .venv/bin/python bench/fw_pico_rate.py [--run-ms 250]

About 3-5 minutes on a 2-core machine (the chip runs at ~0.2x real time).
"""

import argparse
import ast
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
BOARD_SCRIPT = ROOT / "bench" / "mpy" / "pico_rate_board.py"
BUS_BITS = 576  # bit-times per sensor per sample (6 x (RREG 39 + RDATA 57))
CASES = (("python", 1, 1000), ("native", 1, 1000), ("python", 2, 500), ("native", 2, 500))
CLOCK_MHZ = 125


def two_sensor_scene(tmp):
    """The press scene with two sensors (one per I2C controller)."""
    src = (ROOT / "sim" / "tactile_sim" / "scenes" / "press.toml").read_text()
    path = pathlib.Path(tmp) / "press2.toml"
    path.write_text(src.replace("[board]\n", "[board]\nsensors = 2\n", 1))
    return path


def chip(scene, flash, bus_time):
    """An emulated Pico served on a pty in a thread (as tests/pico_target.serve)."""
    from tactile_sim.emulator.servers import serve

    return serve(str(scene), core="rp2040", flash=flash, bus_time=bus_time)


def on_chip(transport, params, timeout_s=900):
    """Run the board script with ``params`` prepended; its result dict."""
    head = f"PARAMS = {params!r}\n"
    transport.enter_raw_repl(soft_reset=True)
    transport.exec_raw_no_follow(head + BOARD_SCRIPT.read_text())
    port, out, end = transport.serial, b"", time.monotonic() + timeout_s
    while time.monotonic() < end:
        out += port.read(max(1, port.in_waiting))  # the board's frames, then the result
        at = out.find(b"\x00BENCH ")
        if at >= 0 and out.find(b"\n", at) > 0:
            line = out[at + 7 : out.find(b"\n", at)].decode()
            while not out.endswith(b"\x04>") and time.monotonic() < end:
                out += port.read(max(1, port.in_waiting))
            return ast.literal_eval(line.strip())
        if b"Traceback" in out and out.endswith(b"\x04>"):
            tail = out[out.rfind(b"Traceback") :].decode(errors="replace")
            raise RuntimeError(f"the board script failed:\n{tail}")
    raise RuntimeError(f"no result within {timeout_s} s")


def measure(scene, flash, bus_time, run_us):
    from mpremote.transport_serial import SerialTransport

    results = {}
    with chip(scene, flash, bus_time) as server:
        transport = SerialTransport(server.path, baudrate=115200)
        try:
            for core, n, target in CASES:
                params = {"CORE": core, "N_SENSORS": n, "TARGET_HZ": target, "RUN_US": run_us}
                t0 = time.monotonic()
                results[core, n] = r = on_chip(transport, params)
                print(f"  bus time {'on ' if bus_time else 'off'} {core:6} {n} sensor(s): "
                      f"{summary(r, n)} ({time.monotonic() - t0:.0f} s)", flush=True)  # fmt: skip
        finally:
            transport.close()
    return results


def per_sample_us(r, n):
    samples, _over, _drop, work, *_ = r["target"]
    return work * n / max(1, samples)


def share_left(r):
    _samples, _over, _drop, work, _wp, _polls, elapsed = r["target"]
    return max(0.0, 1.0 - work / elapsed)


def summary(r, n):
    samples, over, drop, work, wpolls, polls, elapsed = r["target"]
    return (f"{per_sample_us(r, n):.0f} us a sample, {100 * share_left(r):.0f} % left at target "
            f"({samples} samples, {over} late, {drop} dropped, {polls} polls in "
            f"{elapsed / 1000:.0f} ms), max {r['max_hz']} Hz, tried {r['tried']}")  # fmt: skip


def table(bus, free):
    rows = ["| board | sensors | target | work a sample, bus time on (us) | CPU left at target | "
            "highest rate | work a sample, no bus time (us) | + bus time 576 us/sensor | "
            "highest rate, no bus time | CPU per sample per sensor (us) |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for core, n, target in CASES:
        b, f = bus[core, n], free[core, n]
        cpu = per_sample_us(f, n)
        late = b["target"][1]
        left = f"none ({late} late)" if late else f"{100 * share_left(b):.0f} %"
        rows.append(
            f"| {core} | {n} | {target} Hz | {per_sample_us(b, n):,.0f} | {left} | "
            f"{b['max_hz']:,} Hz | {cpu:,.0f} | {cpu + BUS_BITS * n:,.0f} | "
            f"{f['max_hz']:,} Hz | {cpu / n:,.0f} |"
        )
    return "\n".join(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run-ms", type=int, default=250, help="chip time per measured run")
    args = ap.parse_args(argv)
    from tactile.board import flashing
    from tactile.errors import TactileError
    from tactile_sim.emulator import pico_core

    try:
        pico_core.rp2_dir(), pico_core.node(), pico_core.ensure_npm()
        flashing.find_mpremote()
    except TactileError as exc:
        print(f"fw_pico_rate: {exc}", file=sys.stderr)
        return 4
    with tempfile.TemporaryDirectory(prefix="pico-rate-") as tmp:
        scene, flash = two_sensor_scene(tmp), pathlib.Path(tmp) / "pico.flash"
        with chip(scene, flash, True) as server:
            flashing.flash(server.path, n_sensors=1)
        print("flashed; measuring with bus time", flush=True)
        bus = measure(scene, flash, True, args.run_ms * 1000)
        print("measuring without bus time", flush=True)
        free = measure(scene, flash, False, args.run_ms * 1000)
    print()
    print(table(bus, free))
    print()
    print(f"chip clock {CLOCK_MHZ} MHz; work = polls with a sample due or a read pending; "
          "rates searched up to the converters' 2 kSPS")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
