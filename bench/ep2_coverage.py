"""EP2 interval calibration: coverage of the 95 % intervals of S, k1, k2 and radius.

Run: .venv/bin/python bench/ep2_coverage.py [--trials 200]
For each object and noise level: the fraction of trials whose interval holds the true
value (nominal 0.95), and how often the label is right / uncertain / confidently wrong.
The true value is the estimand: the shape operator of the TRUE surface averaged over the
same 8 x 8 grid (the contacts' box, [0, 4]^2; the patch frame of these centred objects is
the world frame).  For spheres and cylinders that is the constant curvature; for the
quadric saddle, whose curvature varies, it differs from the apex value.
"""

import argparse

import numpy as np

from tactile.ep2 import analyze_patch
from tactile.ep2.shape_index import shape_index
from tactile.ep2.surface_geometry import eigen, shape_entries
from tactile_sim.ep2 import make, sweep

CASES = (
    ("cylinder", 8.0),
    ("cylinder", 30.0),
    ("sphere", 10.0),
    ("concave_cylinder", 11.25),
    ("saddle", 10.0),
    ("plane", 1.0),
    ("cylinder", 200.0),
)
LABEL = {
    "cylinder": "cylinder",
    "sphere": "sphere",
    "concave_cylinder": "concave_cylinder",
    "saddle": "saddle",
    "plane": "plane",
}


def grid_truth(obj, grid=8, step=1e-5):
    """(k1, k2, S) of the true surface's shape operator averaged over the grid on [0, 4]^2."""
    g = np.linspace(0.0, 4.0, grid)
    x, y = (v.ravel() for v in np.meshgrid(g, g, indexing="ij"))
    _, zx, zy = obj.eval(x, y)
    _, zx_p, zy_p = obj.eval(x + step, y)
    _, zx_m, zy_m = obj.eval(x - step, y)
    _, _, zy_py = obj.eval(x, y + step)
    _, _, zy_my = obj.eval(x, y - step)
    zxx = (zx_p - zx_m) / (2 * step)
    zxy = (zy_p - zy_m) / (2 * step)
    zyy = (zy_py - zy_my) / (2 * step)
    a, b, c = (e.mean() for e in shape_entries(zx, zy, zxx, zxy, zyy))
    k1, k2 = eigen(a, b, c)
    s = None if max(abs(k1), abs(k2)) < 1e-9 else float(shape_index(k1, k2))
    return float(k1), float(k2), s


def _in(iv, v):
    return iv is not None and iv[0] <= v <= iv[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=200)
    args = ap.parse_args()
    print(
        "| object | noise | stated | S cover | k1 cover | k2 cover | radius cover"
        " | right | uncertain | plane | wrong |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for kind, radius in CASES:
        for noise in (0.005, 0.02):
            for stated in (False, True):
                obj = make(kind, radius, 25.0)
                k1t, k2t, st = grid_truth(obj)
                cov = np.zeros(4)
                n_cov = 0
                lab = {"right": 0, "uncertain": 0, "plane": 0, "wrong": 0}
                for t in range(args.trials):
                    d = sweep(obj, noise_pos=noise, noise_normal=noise, seed=1000 + t)
                    kw = {"noise_pos": noise, "noise_normal": noise} if stated else {}
                    r = analyze_patch(d["points"], d["normals"], **kw)
                    if r.shape == LABEL[kind]:
                        lab["right"] += 1
                    elif r.shape in ("uncertain", "plane"):
                        lab[r.shape] += 1
                    else:
                        lab["wrong"] += 1
                    if st is not None and r.S_interval is not None:
                        n_cov += 1
                        kt = max(abs(k1t), abs(k2t))
                        cov += [
                            _in(r.S_interval, st),
                            _in(r.k1_interval, k1t),
                            _in(r.k2_interval, k2t),
                            _in(r.radius_interval, 1 / kt if kt else np.inf),
                        ]
                c = cov / max(n_cov, 1)
                n = args.trials
                cells = " | ".join(f"{v:.2f}" if n_cov else "-" for v in c)
                print(
                    f"| {kind} R{radius:g} | {noise:g} | {'yes' if stated else 'no'} | {cells}"
                    f" | {lab['right'] / n:.2f} | {lab['uncertain'] / n:.2f}"
                    f" | {lab['plane'] / n:.2f} | {lab['wrong'] / n:.3f} |"
                )


if __name__ == "__main__":
    main()
