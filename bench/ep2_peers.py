"""EP2 peers: this fit vs FITPACK vs 2-jet, RMS error of S and k1 over noise, and run time.

Run: .venv/bin/python bench/ep2_peers.py [--trials 600]
Objects: convex cylinder R 10 and sphere R 10 (random rotation), concave cylinder R 10, in
turn, on the default three-finger sweep (36 contacts, patch 4 x 4).  Noise sigma on each
position coordinate (unit) and on the normal direction per tangent axis (rad) are equal.
S of this fit is S at the patch centre (the default) or the thesis's grid mean (8 x 8);
of the jets, S at the centre.  The 2-jets are given the true noise; this fit's default is
not (it estimates it).  Table 1 pools the objects; table 2 splits the key estimators by
object; table 3 is the paired ratio default / 2-jet with normals with a bootstrap 95 %
interval.
"""

import argparse
import time

import numpy as np

from tactile.ep2 import analyze_patch, peers
from tactile.ep2.shape_index import shape_index
from tactile_sim.ep2 import make, sweep

NOISES = (0.0, 0.002, 0.005, 0.01, 0.02, 0.05)
OBJECTS = (("cylinder", 10.0), ("sphere", 10.0), ("concave_cylinder", 10.0))
DEFAULT = "this (default: centre jet, round/quadric chosen)"
JET = "2-jet, with normals"
SPLIT = (
    DEFAULT,
    "this, spline deg 2 auto (previous default)",
    JET,
    "2-jet, with normals + this debiasing",
)


def _ours(d, grid_mean=False, **kw):
    """(k1, k2): at the patch centre (the default) or the grid maps (the thesis's mean)."""
    r = analyze_patch(d["points"], d["normals"], maps=grid_mean, **kw)
    if grid_mean:
        return r.maps["k1"], r.maps["k2"]
    return np.array([r.k1]), np.array([r.k2])


def estimators(sig):
    sp = max(sig, 1e-6)
    return {
        DEFAULT: lambda d: _ours(d),
        "this, thesis statistic (grid-mean S)": lambda d: _ours(d, grid_mean=True),
        "this, noise stated": lambda d: _ours(d, noise_pos=sp, noise_normal=sp),
        "this, spline deg 2 auto (previous default)": lambda d: _ours(d, method="spline"),
        "this, thesis (spline deg 3, tangent)": lambda d: _ours(
            d, method="spline", order=3, weighting="tangent"
        ),
        "FITPACK bisplrep (pos)": lambda d: peers.fitpack(d["points"], d["normals"], sp),
        "LSQBivariateSpline (pos)": lambda d: peers.lsq_spline(d["points"], d["normals"]),
        "2-jet, positions": lambda d: peers.jet(d["points"], d["normals"], sp, sp, False),
        JET: lambda d: peers.jet(d["points"], d["normals"], sp, sp, True),
        "2-jet, with normals + this debiasing": lambda d: peers.jet(
            d["points"], d["normals"], sp, sp, True, debias=True
        ),
    }


def run(sig, trials):
    """Errors (S, relative k1) per estimator and object, and total run time per estimator."""
    rng = np.random.default_rng(7)
    ests = estimators(sig)
    err = {k: {"S": [], "k1": [], "obj": []} for k in ests}
    t_used = dict.fromkeys(ests, 0.0)
    for t in range(trials):
        kind, radius = OBJECTS[t % len(OBJECTS)]
        obj = make(kind, radius, rng.uniform(0, 180))
        d = sweep(obj, noise_pos=sig, noise_normal=sig, seed=t)
        k_true = obj.true_k()
        concave = kind == "concave_cylinder"
        for name, fn in ests.items():
            t0 = time.perf_counter()
            k1, k2 = fn(d)
            t_used[name] += time.perf_counter() - t0
            kk, kt = (k2, k_true[1]) if concave else (k1, k_true[0])
            err[name]["S"].append(float(np.mean(shape_index(k1, k2))) - obj.true_s())
            err[name]["k1"].append((float(np.mean(kk)) - kt) / abs(kt))
            err[name]["obj"].append(kind)
    return {k: {q: np.array(v) for q, v in e.items()} for k, e in err.items()}, t_used


def rms(v):
    return float(np.sqrt(np.mean(np.square(v))))


def paired_ratio(a, b, n_boot=400):
    """RMS(a) / RMS(b) over paired trials, with a bootstrap 95 % interval."""
    rng = np.random.default_rng(0)
    idx = rng.integers(0, a.size, (n_boot, a.size))
    boot = np.sqrt(np.mean(a[idx] ** 2, axis=1) / np.mean(b[idx] ** 2, axis=1))
    return rms(a) / rms(b), np.percentile(boot, [2.5, 97.5])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=600)
    args = ap.parse_args()
    results = {sig: run(sig, args.trials) for sig in NOISES}
    print("| noise | estimator | RMS S error | RMS k1 error (rel) | us/patch |")
    print("|---|---|---|---|---|")
    for sig, (err, t_used) in results.items():
        for name, e in err.items():
            us = 1e6 * t_used[name] / args.trials
            print(f"| {sig:g} | {name} | {rms(e['S']):.5f} | {rms(e['k1']):.4f} | {us:.0f} |")
    print()
    kinds = [k for k, _ in OBJECTS]
    print("| noise | estimator | " + " | ".join(f"RMS S {k}" for k in kinds) + " |")
    print("|---|---|" + "---|" * len(kinds))
    for sig, (err, _) in results.items():
        for name in SPLIT:
            e = err[name]
            cells = " | ".join(f"{rms(e['S'][e['obj'] == k]):.5f}" for k in kinds)
            print(f"| {sig:g} | {name} | {cells} |")
    print()
    print("| noise | RMS S default / 2-jet with normals | bootstrap 95 % |")
    print("|---|---|---|")
    for sig, (err, _) in results.items():
        r, (lo, hi) = paired_ratio(err[DEFAULT]["S"], err[JET]["S"])
        print(f"| {sig:g} | {r:.3f} | {lo:.3f} - {hi:.3f} |")


if __name__ == "__main__":
    main()
