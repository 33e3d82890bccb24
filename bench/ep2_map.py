"""``tactile ep2 map`` on the four map objects (``tactile_sim.ep2.map_objects``).

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_map.py [--split tune] [--trials 30]
     [--noise-pos 0.005] [--noise-normal 0.005]

``--split tune`` draws the noise from seeds 0, 1, ...; ``--split holdout`` from seeds
1000, 1001, ... and is FOR FINAL EVALUATION ONLY: it is refused without ``--final``.

Per object, over ``--trials`` noise draws (noise stated to the map): the share of maps
with the right number of regions, with every region labelled right (in order of the truth's
labels, matched as multisets), and with every true edge matched by a found edge of its kind
within 2 mm (0.2 cm) of the true edge line and 5 deg of its direction; the worst distance
and angle seen; over the creases (ridges, valleys) matched, the share whose stated
``direction_err_deg`` holds the true direction, and its median.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_args import add_split, check_split, positive_int  # noqa: E402

from tactile.ep2.region_map import map_contacts  # noqa: E402
from tactile_sim.ep2 import map_objects  # noqa: E402

MAX_CM, MAX_DEG = 0.2, 5.0
SEED0 = {"tune": 0, "holdout": 1000}  # holdout: FOR FINAL EVALUATION ONLY


def _match(truth, found):
    """(distance cm, angle deg, half-angle deg or None) of the best found edge of the
    truth's kind, or None."""
    best = None
    d = np.asarray(truth["direction"], float)
    for e in found:
        if e.kind != truth["kind"] or e.direction is None:
            continue
        off = np.asarray(e.point) - truth["point"]
        dist = float(np.linalg.norm(off - (off @ d) * d))
        ang = math.degrees(math.acos(min(1.0, abs(float(np.dot(e.direction, d))))))
        if best is None or dist + ang / 25 < best[0] + best[1] / 25:
            best = (dist, ang, e.direction_err_deg)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_split(ap, SEED0)
    ap.add_argument("--trials", type=positive_int, default=30)
    ap.add_argument("--noise-pos", type=float, default=0.005)
    ap.add_argument("--noise-normal", type=float, default=0.005)
    args = ap.parse_args(argv)
    check_split(ap, args)
    print(f"split {args.split}, {args.trials} seeds from {SEED0[args.split]}\n")
    print("| object | contacts | regions right | labels right | edges within 2 mm, 5 deg |"
          " worst edge (mm, deg) | crease dir. cover | median crease dir. half-angle (deg)"
          " |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for name in map_objects.NAMES:
        count = labels = placed = 0
        worst, cover, halves = [0.0, 0.0], [], []
        for seed in range(SEED0[args.split], SEED0[args.split] + args.trials):
            d = map_objects.make(name, args.noise_pos, args.noise_normal, seed=seed)
            m = map_contacts(d["points"], d["normals"], noise_pos=args.noise_pos or None,
                             noise_normal=args.noise_normal or None)  # fmt: skip
            count += len(m.regions) == len(d["regions"])
            labels += Counter(r.shape for r in m.regions) == Counter(
                r["shape"] for r in d["regions"]
            )
            ok = True
            for tr in d["edges"]:
                got = _match(tr, m.edges)
                if got is None:
                    ok = False
                    continue
                worst = [max(worst[0], got[0] * 10), max(worst[1], got[1])]
                if tr["kind"] != "curvature jump":
                    cover.append(got[1] <= got[2])
                    halves.append(got[2])
                ok &= got[0] <= MAX_CM and got[1] <= MAX_DEG
            placed += ok
        n = args.trials
        print(
            f"| {name} | {len(d['points'])} | {count / n:.2f} | {labels / n:.2f} |"
            f" {placed / n:.2f} | {worst[0]:.2f}, {worst[1]:.2f} |"
            + (f" {np.mean(cover):.2f} ({len(cover)}) | {np.median(halves):.2f} |" if cover
               else " - | - |")
        )  # fmt: skip


if __name__ == "__main__":
    main()
