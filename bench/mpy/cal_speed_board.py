"""Runs on MicroPython: the float calibration (cal_old) against the fixed point, per call."""

import gc
import time

import cal_old

from tactile_fw import calibration

coeffs = [(1.5e-6 if r == c else 2.5e-8 * (r - c)) for r in range(6) for c in range(6)]
g = [1234567, -2345678, 345678, -45678, 5678901, -678901]
out = [0] * 6
best = {}
for _ in range(8):
    for name, cal in (
        ("float", cal_old.Calibration(coeffs)),
        ("fixed", calibration.Calibration(coeffs)),
    ):
        gc.collect()
        a0 = gc.mem_alloc()
        t0 = time.ticks_us()
        for _ in range(3000):
            cal.apply(g, out)
        dt = time.ticks_diff(time.ticks_us(), t0)
        best[name] = min(best.get(name, 1e9), dt / 3000)
        alloc = (gc.mem_alloc() - a0) // 3000
print("float us", best["float"], "fixed us", best["fixed"], "last alloc", alloc)
