"""Fixed-point calibration against the float product it replaced: how far apart, in uN.

The firmware (Python and C) computes F/T = C (g - bias) in integers
(``tactile_fw/calibration.py``); before, it computed ``round(1e6 C (g - bias))`` in
double precision with a float bias. For the emulator's transducer model
(``tactile_sim.emulator.ft_model``) at several full-scale ranges, this draws gauge
codes over the converter's whole 24-bit range and over the model's own full scale
(60 % of it), a TARE bias from 7 samples, and prints the largest and RMS difference
per row kind (forces in uN, torques in uN*m), beside the analytic bound

    |fixed - float| <= 1 + 2^-(S+1) sum_j |g_j - b_j| + sum_j |K_j| / 512

(A's rounding, the bias's 1/256 count, the final rounding).

    .venv/bin/python bench/fw_cal_fixed.py
"""

import numpy as np

from tactile_fw.calibration import Calibration
from tactile_sim.emulator.ft_model import FULL_SCALE_CODE, sensitivity_matrix

N_CODES = 20_000


def compare(force_range, torque_range, span, rng):
    c = np.linalg.inv(sensitivity_matrix(force_range, torque_range)).astype(np.float32)
    cal = Calibration([float(v) for v in c.ravel()])
    sums = rng.integers(-200_000 * 7, 200_000 * 7, 6)
    cal.set_bias_sums([int(v) for v in sums], 7)
    bias = sums / 7
    g = rng.integers(-span, span, (N_CODES, 6))
    got = np.empty((N_CODES, 6))
    out = [0] * 6
    for k in range(N_CODES):
        cal.apply([int(v) for v in g[k]], out)
        got[k] = out
    ref = np.rint(1e6 * (c.astype(np.float64) @ (g - bias).T).T)
    diff = np.abs(got - ref)
    k = np.abs(1e6 * c.astype(np.float64))
    step = np.array([2.0 ** -(s + 1) for s in cal.shift])
    bound = 1 + step[None, :] * np.abs(g - bias).sum(axis=1)[:, None] + k.sum(axis=1) / 512
    assert np.all(diff <= bound)
    rms = np.sqrt(np.mean(diff**2, axis=0))
    return diff[:, :3].max(), rms[:3].max(), diff[:, 3:].max(), bound[:, :3].max()


def main():
    rng = np.random.default_rng(1)
    print("| force range | codes | max |dF| (uN) | RMS dF (uN) | max |dT| (uN*m) | bound F (uN) |")
    print("|---:|---|---:|---:|---:|---:|")
    for force, torque in ((10.0, 0.5), (50.0, 2.0), (500.0, 20.0)):
        for label, span in (("model full scale", int(FULL_SCALE_CODE)), ("24-bit range", 1 << 23)):
            mf, rf, mt, bf = compare(force, torque, span, rng)
            print(f"| {force:g} N | {label} | {mf:.0f} | {rf:.2f} | {mt:.0f} | {bf:.0f} |")


if __name__ == "__main__":
    main()
