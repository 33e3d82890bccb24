"""EP2 error against run time over order x grid x solver x weighting; picks the defaults.

Run: .venv/bin/python bench/ep2_tradeoff.py [--trials 60] [--png docs/ep2_tradeoff.png]
Data: cylinders and spheres R 10 at random rotation, noise 0.01 (position, unit) and
0.01 rad (normals), 36 contacts.  Error = RMS of S_patch - S_true.
"""

import argparse
import time

import numpy as np

from tactile.ep2 import analyze_patch
from tactile_sim.ep2 import make, sweep


def run(trials, noise):
    rng = np.random.default_rng(11)
    data = []
    for t in range(trials):
        kind = ("cylinder", "sphere", "concave_cylinder")[t % 3]
        obj = make(kind, 10.0, rng.uniform(0, 180))
        data.append((obj.true_s(), sweep(obj, noise_pos=noise, noise_normal=noise, seed=t)))
    rows = []
    for degree in (2, 3, 4):
        for grid in (4, 8, 16):
            for solver in ("svd", "qr", "gelsy"):
                for weighting in ("auto", "tangent", "position"):
                    err, t_used = [], 0.0
                    for s_true, d in data:
                        t0 = time.perf_counter()
                        r = analyze_patch(
                            d["points"],
                            d["normals"],
                            degree=degree,
                            grid=grid,
                            solver=solver,
                            weighting=weighting,
                        )
                        t_used += time.perf_counter() - t0
                        s = r.S_patch if r.S_patch is not None else 0.0
                        err.append(s - s_true)
                    rows.append(
                        (
                            degree,
                            grid,
                            solver,
                            weighting,
                            float(np.sqrt(np.mean(np.square(err)))),
                            1e3 * t_used / trials,
                        )
                    )
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--png")
    args = ap.parse_args()
    rows = run(args.trials, args.noise)
    print("| degree | grid | solver | weighting | RMS S error | ms/patch |")
    print("|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: r[4]):
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.4f} | {r[5]:.3f} |")
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        for w, m in (("auto", "o"), ("tangent", "s"), ("position", "^")):
            for deg, col in ((2, "C0"), (3, "C1"), (4, "C2")):
                pts = [(r[5], r[4]) for r in rows if r[3] == w and r[0] == deg]
                ax.scatter(
                    *zip(*pts, strict=True), marker=m, color=col, s=14, label=f"deg {deg}, {w}"
                )
        ax.set_xlabel("ms per patch")
        ax.set_ylabel("RMS S error")
        ax.set_yscale("log")
        ax.legend(fontsize=6, ncol=3)
        fig.tight_layout()
        fig.savefig(args.png, dpi=120)


if __name__ == "__main__":
    main()
