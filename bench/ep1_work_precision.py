"""Work-precision of the rolling simulation (eqs. 24-28) for every solve_ivp method.

Error at the end of a 1 rad roll (omega = (0.6, 0.8, 0) in the contact frame) against the
sphere's closed form (eq. 38 integrated) and against a DOP853 rtol=1e-13 reference for a
paraboloid (eq. 36, C = 1 at (1.0, 0.1)) and an ellipsoid (1.5, 0.8, 1.2 at (0.2, 0.3))
(that reference is itself checked against Radau at rtol=1e-12).  Time is the best of
``REPEATS`` runs (5: on a shared, loaded machine fewer left 2x outliers in the figure).

Run: .venv/bin/python bench/ep1_work_precision.py [--png docs/ep1_work_precision.png]
"""

import argparse
import time

import numpy as np

from tactile.output.plots import log_ticks
from tactile_sim.ep1 import surfaces as S
from tactile_sim.ep1.rolling import roll, sphere_on_sphere

METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
RTOLS = (1e-3, 1e-5, 1e-7, 1e-9, 1e-11)
OMEGA = (0.6, 0.8, 0.0)
REPEATS = 5
FINGER = S.fingertip(1.0)
CASES = {
    "sphere R2=2": (S.sphere(2.0), (0.0, 0.0)),
    "paraboloid C=1": (S.paraboloid(1.0), (1.0, 0.1)),
    "ellipsoid": (S.ellipsoid(1.5, 0.8, 1.2), (0.2, 0.3)),
}


def run(obj, p2, method, rtol):
    return roll(
        FINGER, obj, (0.1, -0.1), p2, 0.0, OMEGA, method=method, rtol=rtol, atol=rtol * 1e-2
    )


def reference(name, obj, p2):
    if name.startswith("sphere"):
        u, v, _ = sphere_on_sphere(1.0, 2.0, 0.1, -0.1, OMEGA[0], OMEGA[1], 1.0)
        return np.array([u, v]), None
    ref = run(obj, p2, "DOP853", 1e-13).y[:5]
    check = run(obj, p2, "Radau", 1e-12).y[:5]
    return ref, float(np.abs(ref - check).max())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--png", default=None)
    args = ap.parse_args()
    results = []
    print("| object | method | rtol | max error | time (ms) | nfev |")
    print("|---|---|---:|---:|---:|---:|")
    for name, (obj, p2) in CASES.items():
        ref, agree = reference(name, obj, p2)
        if agree is not None:
            print(f"| {name} | (reference DOP853 1e-13 vs Radau 1e-12: {agree:.1e}) | | | | |")
        for method in METHODS:
            for rtol in RTOLS:
                best, res = np.inf, None
                for _ in range(REPEATS):
                    t = time.perf_counter()
                    res = run(obj, p2, method, rtol)
                    best = min(best, time.perf_counter() - t)
                err = float(np.abs(res.y[: len(ref)] - ref).max())
                results.append((name, method, rtol, err, best))
                print(
                    f"| {name} | {method} | {rtol:.0e} | {err:.1e} | {best * 1e3:.1f} "
                    f"| {res.nfev} |"
                )
    if args.png:
        plot(results, args.png)


def plot(results, path):
    """Error against time per method, one panel per object; legend outside the panels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(CASES)
    fig, axes = plt.subplots(
        1, len(names), figsize=(4.0 * len(names) + 1.4, 3.6), sharey=True, layout="constrained"
    )
    for ax, name in zip(axes, names, strict=True):
        for method in METHODS:
            pts = [  # in rtol order: a line runs from loose to tight tolerance
                (t * 1e3, max(e, 1e-16)) for n, m, _, e, t in results if n == name and m == method
            ]
            x, y = np.array(pts).T
            ax.loglog(x, y, "o-", ms=3, label=method)
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        log_ticks(ax.xaxis)
        log_ticks(ax.yaxis)
    axes[0].set_ylabel("max error at the roll's end (rad)")
    fig.supxlabel(f"run time per roll (ms, best of {REPEATS})", fontsize=10)
    axes[-1].legend(
        title="solve_ivp method\n(rtol 1e-3 ... 1e-11)", title_fontsize=8, fontsize=8,
        loc="upper left", bbox_to_anchor=(1.03, 1.0), borderaxespad=0.0,
    )  # fmt: skip
    fig.suptitle(
        "Rolling simulation (eqs. 24-28), 1 rad roll: work against precision\n(error: max over"
        " u1, v1, u2, v2, \u03c8; a paraboloid's u2, v2 in units of R1 = 1; floor 1e-16)",
        fontsize=10,
    )
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
