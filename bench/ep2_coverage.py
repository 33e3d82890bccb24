"""EP2 interval calibration: coverage of the 95 % intervals of S, k1, k2 and radius.

Run: .venv/bin/python bench/ep2_coverage.py [--trials 200]
For each object and noise level: the fraction of trials whose interval holds the true
value (nominal 0.95), and how often the label is right / uncertain / confidently wrong.
"""

import argparse

import numpy as np

from tactile.ep2 import analyze_patch
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
                k1t, k2t = obj.true_k()
                st = obj.true_s()
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
