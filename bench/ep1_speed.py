"""EP1 speed: ``estimate()`` one point at a time beside ``estimate_batch()``, and the fig. 16 grid.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep1_speed.py   (Markdown tables, ~30 s)
``estimate()`` is ``estimate_batch()`` of a stack of one point; target: the fig. 16 grid
within 10 s.  Each figure is the median of several repeats, each repeat
long enough (>= 50 ms) to average the timer, as wall-clock and as this process's CPU time
(which other jobs on a shared machine inflate less).  Single calls and batches run in the
same process on the same points, so their ratio holds on a loaded machine.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from tactile.ep1.estimator import STATUSES, estimate, estimate_batch  # noqa: E402
from tactile_sim.ep1.probes import measure, sphere_plus_probes  # noqa: E402
from tactile_studies.ep1.studies import study_noise  # noqa: E402

R1, SIGMA = 1.0, 0.001
REPEATS = 7


def median_s(fn, repeats=REPEATS, min_time=0.05):
    """(wall, CPU) median seconds per call of ``fn`` over ``repeats`` of at least ``min_time``
    (the calibration runs warm up short calls; a long call counts as its own first repeat)."""
    number = 1
    while (t := _seconds(fn, number))[0] < min_time:
        number *= 2
    times = [t] + [_seconds(fn, number) for _ in range(repeats - 1)]
    return tuple(statistics.median(x) / number for x in zip(*times, strict=True))


def _seconds(fn, number):
    w0, c0 = time.perf_counter(), time.process_time()
    for _ in range(number):
        fn()
    return time.perf_counter() - w0, time.process_time() - c0


def points(n, rng):
    """n EP1 points: '+' probes (8) on spheres of radius 0.01-100 R1, dtheta 0.2, noisy."""
    radii = np.exp(rng.uniform(np.log(0.01), np.log(100), n))
    return measure(sphere_plus_probes(R1, radii, 0.2), R1, sigma_theta=SIGMA, rng=rng)


def single_loop(pts):
    for p in pts:
        estimate(p[:, :2], p[:, 2:], R1, sigma_theta=SIGMA)


def batch(pts):
    return estimate_batch(pts[..., :2], pts[..., 2:], R1, sigma_theta=SIGMA)


def agreement(pts):
    """Statuses equal, and the largest |kx - kx_batch| / |kx| over the resolved points."""
    out = batch(pts)
    same, worst = 0, 0.0
    for i, p in enumerate(pts):
        e = estimate(p[:, :2], p[:, 2:], R1, sigma_theta=SIGMA)
        same += e.status == STATUSES[out["code"][i]]
        if e.kx is not None:
            worst = max(worst, abs(e.kx - out["kx"][i]) / abs(e.kx))
    return same, worst


def main():
    rng = np.random.default_rng(0)
    load = os.getloadavg()[0]
    print("| points | `estimate()` in a loop: wall / CPU us per point "
          "| `estimate_batch()`: wall / CPU us per point | single / batch (CPU) |")  # fmt: skip
    print("|---:|---:|---:|---:|")
    for n in (1, 100, 10_000, 100_000):
        pts = points(n, rng)
        repeats = 3 if n > 10_000 else REPEATS
        one = median_s(lambda p=pts: single_loop(p), repeats)
        many = median_s(lambda p=pts: batch(p), repeats)
        print(f"| {n} | {one[0] / n * 1e6:.2f} / {one[1] / n * 1e6:.2f} "
              f"| {many[0] / n * 1e6:.2f} / {many[1] / n * 1e6:.2f} "
              f"| {one[1] / many[1]:.2g} |")  # fmt: skip
    same, worst = agreement(points(10_000, rng))
    print(f"\nsingle vs batch on 10000 points: {same}/10000 statuses equal, "
          f"max relative kx difference {worst:.1e}")  # fmt: skip
    wall, cpu = median_s(lambda: study_noise(trials=100), repeats=3)
    print("\n| fig. 16 grid (9 radii x 4 dtheta x 7 noise x 100 trials = 25200 estimates) | s |")
    print("|---|---:|")
    print(f"| simulate (closed form, eq. 38) + measure + `estimate_batch`: wall / CPU, median "
          f"of 3 | {wall:.3f} / {cpu:.3f} |")  # fmt: skip
    print(f"\nload average: {load:.2f} at the start, {os.getloadavg()[0]:.2f} at the end "
          f"({os.cpu_count()} cores)")  # fmt: skip


if __name__ == "__main__":
    main()
