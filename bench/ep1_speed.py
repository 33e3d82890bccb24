"""EP1 speed: estimator per point (single call and batched) and the full fig. 16 grid.

Run: .venv/bin/python bench/ep1_speed.py   (prints a Markdown table)
Targets (issue 4): estimator <= 20 us per point in-process; fig. 16 grid <= 10 s.
"""

import time

import numpy as np

from tactile.ep1.estimator import estimate, estimate_batch
from tactile_sim.ep1.probes import measure, sphere_plus_probes
from tactile_sim.ep1.studies import study_noise


def best_of(fn, repeat=5, number=1):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t) / number)
    return best


def main():
    rng = np.random.default_rng(0)
    one = measure(sphere_plus_probes(1.0, 2.0, 0.2), 1.0, sigma_theta=0.001, rng=rng)
    th, dp = one[:, :2], one[:, 2:]
    rows = []
    t = best_of(lambda: estimate(th, dp, 1.0, sigma_theta=0.001), number=200)
    rows.append(("`estimate` (one point, full result object)", 1, t * 1e6))
    t = best_of(lambda: estimate_batch(th, dp, 1.0), number=200)
    rows.append(("`estimate_batch`, 1 point", 1, t * 1e6))
    for n in (100, 10_000, 100_000):
        radii = np.exp(rng.uniform(np.log(0.01), np.log(100), n))
        many = measure(sphere_plus_probes(1.0, radii, 0.2), 1.0, sigma_theta=0.001, rng=rng)
        t = best_of(lambda m=many: estimate_batch(m[..., :2], m[..., 2:], 1.0), repeat=3)
        rows.append((f"`estimate_batch`, {n} points", n, t / n * 1e6))
    t_grid = best_of(lambda: study_noise(trials=100), repeat=3)
    print("| what | points | us per point |")
    print("|---|---:|---:|")
    for name, n, us in rows:
        print(f"| {name} | {n} | {us:.2f} |")
    print()
    print("| fig. 16 grid (9 radii x 4 dtheta x 7 noise x 100 trials = 25200 estimates) | s |")
    print("|---|---:|")
    print(f"| simulate (closed form, eq. 38) + measure + estimate, best of 3 | {t_grid:.3f} |")


if __name__ == "__main__":
    main()
