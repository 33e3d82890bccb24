"""EP2 peers: this fit vs FITPACK vs 2-jet, RMS error of S and k1 over noise, and run time.

Run: .venv/bin/python bench/ep2_peers.py [--trials 200]
Objects: convex cylinder R 10 and sphere R 10 (random rotation), concave cylinder R 10, on
the default three-finger sweep (36 contacts, patch 4 x 4).  Noise sigma on each position
coordinate (unit) and on the normal direction per tangent axis (rad) are equal.
S of a grid estimator is the grid mean (8 x 8); of the jet, S at the centre.
"""

import argparse
import time

import numpy as np

from tactile.ep2 import analyze_patch, peers
from tactile.ep2.shape_index import shape_index
from tactile_sim.ep2 import make, sweep

NOISES = (0.0, 0.002, 0.005, 0.01, 0.02, 0.05)
OBJECTS = (("cylinder", 10.0), ("sphere", 10.0), ("concave_cylinder", 10.0))


def _ours(d, sig, grid_mean=False, **kw):
    """(k1, k2): of the grid-mean shape operator (S_patch, the default) or the grid maps."""
    r = analyze_patch(d["points"], d["normals"], maps=grid_mean, **kw)
    if grid_mean:
        return r.maps["k1"], r.maps["k2"]
    return np.array([r.k_patch[0]]), np.array([r.k_patch[1]])


def estimators(sig):
    sp = max(sig, 1e-6)
    return {
        "this (default: deg 2, auto; S_patch)": lambda d: _ours(d, sig),
        "this, thesis statistic (grid-mean S)": lambda d: _ours(d, sig, grid_mean=True),
        "this, noise stated": lambda d: _ours(d, sig, noise_pos=sp, noise_normal=sp),
        "this, thesis (deg 3, tangent)": lambda d: _ours(d, sig, degree=3, weighting="tangent"),
        "FITPACK bisplrep (pos)": lambda d: peers.fitpack(d["points"], d["normals"], sp),
        "LSQBivariateSpline (pos)": lambda d: peers.lsq_spline(d["points"], d["normals"]),
        "2-jet, positions": lambda d: peers.jet(d["points"], d["normals"], sp, sp, False),
        "2-jet, with normals": lambda d: peers.jet(d["points"], d["normals"], sp, sp, True),
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=200)
    args = ap.parse_args()
    rng = np.random.default_rng(7)
    print("| noise | estimator | RMS S error | RMS k1 error (rel) | us/patch |")
    print("|---|---|---|---|---|")
    for sig in NOISES:
        ests = estimators(sig)
        err_s = {k: [] for k in ests}
        err_k = {k: [] for k in ests}
        t_used = dict.fromkeys(ests, 0.0)
        for t in range(args.trials):
            kind, radius = OBJECTS[t % len(OBJECTS)]
            obj = make(kind, radius, rng.uniform(0, 180))
            d = sweep(obj, noise_pos=sig, noise_normal=sig, seed=t)
            s_true = obj.true_s()
            k1_true = obj.true_k()[0] if kind != "concave_cylinder" else 0.0
            k2_true = obj.true_k()[1]
            for name, fn in ests.items():
                t0 = time.perf_counter()
                k1, k2 = fn(d)
                t_used[name] += time.perf_counter() - t0
                err_s[name].append(float(np.mean(shape_index(k1, k2))) - s_true)
                kk = k1 if kind != "concave_cylinder" else k2
                kt = k1_true if kind != "concave_cylinder" else k2_true
                err_k[name].append((float(np.mean(kk)) - kt) / abs(kt))
        for name in ests:
            rs = np.sqrt(np.mean(np.square(err_s[name])))
            rk = np.sqrt(np.mean(np.square(err_k[name])))
            us = 1e6 * t_used[name] / args.trials
            print(f"| {sig:g} | {name} | {rs:.4f} | {rk:.4f} | {us:.0f} |")


if __name__ == "__main__":
    main()
