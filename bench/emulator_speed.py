"""Emulator speed (issue 6): throughput, real-time loss, contact latency.

Run: ``.venv/bin/python bench/emulator_speed.py [--seconds 60] [--fast-only] [--repeat 3]``.

Every run is made for both firmware cores (``--core``, default both): the MicroPython
firmware and the C core (``firmware/c`` through ctypes, the same simulated ADCs and bus as
its HAL), alternating in one process, so that the ratio is measured under the same load.
The fast rows give the best of ``--repeat`` runs per core.

1. As fast as possible: simulated samples per wall second through the whole
   chain (transducer model, ADC models, firmware, encode, pty, host decoder),
   in process through ``sim://`` (no pty), and the emulator alone (no host:
   what the chain would reach with a free host).  Wall time of the pty run
   starts before the host opens the port, so it includes the 50 ms settle.
2. Real time at 1 kHz and 5 kHz (5 kHz is beyond the ADS122C04's 2 kSPS: the
   scene overrides the converter rate, which only the emulator can do), host
   reading a real pty: frames lost.
3. Latency from a contact's onset in scene time to the host receiving its
   CONTACT BEGIN frame, p50 and p99 (1 kHz, 3-sample debounce included).
Emulator and host share one process (two threads), so they also share the GIL.
Every run simulates ``--seconds`` of scene time.
"""

import argparse
import time

import numpy as np
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_sim.emulator.cores import CORES
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer
from tactile_sim.emulator.scene import Scene
from tactile_sim.urlhandler import register

KEYS = [[0.0, 0, 0, 0, 0, 0, 0], [0.05, 0, 0, 0, 0, 0, 0], [0.1, 3.2, 2.4, -1, 0, 0, 0],
        [0.15, 3.2, 2.4, -1, 0, 0, 0], [0.2, 0, 0, 0, 0, 0, 0]]  # fmt: skip


def scene(rate_hz, streams=("contacts", "samples")):
    data = {
        "scene": {"name": f"bench-{rate_hz}"},
        "board": {"rate_hz": rate_hz, "streams": list(streams), "max_rate_hz": max(rate_hz, 0)},
        "sensor": {"bias_counts": 0.0},
        "motion": {"kind": "press", "keyframes": KEYS, "repeat": True},
    }
    if rate_hz <= 1000:
        del data["board"]["max_rate_hz"]
    return Scene(f"<bench {rate_hz} Hz>", data)


def pty_run(rate_hz, seconds, realtime, core):
    board = EmulatedBoard(scene(rate_hz), core=core)
    decoder = StreamDecoder()
    arrivals = []  # (wall time, message) for CONTACT BEGIN
    n = 0
    t0 = time.monotonic()
    with PtyServer(board, realtime=realtime, duration_s=seconds) as server:
        with serial.Serial(server.path, timeout=0.02) as port:
            while server.serving or port.in_waiting:
                data = port.read(1)
                if data:
                    data += port.read(port.in_waiting)
                    now = time.monotonic()
                    for m in decoder.feed(data):
                        n += m.type_name == "SAMPLE"
                        if m.type_name == "CONTACT" and m.phase == C.PHASE_BEGIN:
                            arrivals.append((now - t0, m.timestamp_us))
        wall = time.monotonic() - t0
    return n, wall, decoder.counters, arrivals, board


def inprocess_fast(seconds, core):
    register()
    port = serial.serial_for_url(f"sim://press?core={core}", timeout=0.01)
    decoder = StreamDecoder()
    n = 0
    t0 = time.perf_counter()
    while port.emulator.t_us < seconds * 1e6:
        n += sum(m.type_name == "SAMPLE" for m in decoder.feed(port.read(65536)))
    return n, time.perf_counter() - t0, decoder.counters


def emulator_alone(seconds, core):
    board = EmulatedBoard(scene(1000), core=core)
    t0 = time.perf_counter()
    t = 0
    while t < seconds * 1e6:
        t += 20_000
        board.run_until(t)
        board.read_host()
    return board.board.samples, time.perf_counter() - t0


def onsets(duration_s, enter=1.39):
    board = EmulatedBoard(scene(1000))
    ts = np.arange(0, duration_s, 1e-5)
    f = np.hypot(*board.motion.wrench_at(ts)[:2])
    above = f > enter
    return ts[1:][above[1:] & ~above[:-1]]


def row(label, core, n, wall, lost, damaged, ratio=""):
    print(
        f"| {label} | {core} | {n} | {wall:.2f} | {n / wall:,.0f} | {ratio} | {lost} | {damaged} |"
    )


def _alone(seconds, core):
    n, wall = emulator_alone(seconds, core)
    return n, wall, "-", "-"


def _inprocess(seconds, core):
    n, wall, c = inprocess_fast(seconds, core)
    return n, wall, c.lost_frames, c.damaged


def _pty_fast(seconds, core):
    n, wall, c, _, board = pty_run(1000, seconds, realtime=False, core=core)
    return n, wall, f"{c.lost_frames} (board dropped {board.tx_dropped})", c.damaged


FAST = {
    "fast, emulator alone (no host)": _alone,
    "fast, in process (sim://)": _inprocess,
    "fast, through a pty": _pty_fast,
}


def fast_rows(seconds, cores, repeat):
    """Each fast run for each core, alternating, best of ``repeat``; samples/s / Python's."""
    for label, run in FAST.items():
        best = {}
        for _ in range(repeat):
            for core in cores:
                got = run(seconds, core)
                if core not in best or got[1] < best[core][1]:
                    best[core] = got
        base = best.get("python")
        for core in cores:
            n, wall, lost, damaged = best[core]
            ratio = f"{(n / wall) / (base[0] / base[1]):.2f}" if base else ""
            row(label, core, n, wall, lost, damaged, ratio)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per run")
    ap.add_argument("--fast-only", action="store_true", help="skip the real-time runs")
    ap.add_argument("--repeat", type=int, default=3, help="fast runs per core (best kept)")
    ap.add_argument("--core", choices=CORES, action="append", help="default: both")
    args = ap.parse_args()
    cores = args.core or list(CORES)
    print(
        "| run | core | simulated samples | wall s | samples/s | / python | lost frames | damaged |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    fast_rows(args.seconds, cores, args.repeat)
    if args.fast_only:
        return
    latency = {}
    for rate in (1000, 5000):
        for core in cores:
            n, wall, c, arrivals, _ = pty_run(rate, args.seconds, realtime=True, core=core)
            row(f"real time {rate} Hz, pty", core, n, wall, c.lost_frames, c.damaged)
            if rate == 1000:
                latency[core] = arrivals
    for core, arrivals in latency.items():
        report_latency(core, arrivals, args.seconds)


def report_latency(core, latency, seconds):
    on = onsets(seconds)
    lat = []
    for wall_s, ts_us in latency:
        k = np.argmin(np.abs(on - ts_us / 1e6))
        lat.append((wall_s - on[k]) * 1e3)
    lat = np.array(lat)
    print(
        f"\nContact onset (scene time) to CONTACT BEGIN at the host, {core} core, 1 kHz,"
        f" {len(lat)} contacts:"
        f" p50 {np.percentile(lat, 50):.2f} ms, p99 {np.percentile(lat, 99):.2f} ms,"
        f" max {lat.max():.2f} ms (3-sample debounce = 2-3 ms of it)."
    )


if __name__ == "__main__":
    main()
