"""How near can 9 touches come to the fixed 3 x 6 plan's RMS S?  The error against touches.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/explore_bound.py [--split tune|holdout]
     [--seeds 40] [--only OBJECT ...]

``bench/explore.py`` compares explore's S error at its stop with the fixed plan's after 18
touches.  This bench asks what any 9 touches could do, on the same objects, noise and fit
(``bench/explore.py``'s setup, lengths in cm), every run counted (no stop rule):

- **explore after n touches** (n = 8, 9, 12, 18): ``tactile.explore.Explorer`` run on past
  its stop, the RMS of S - truth at its patch centre after the n-th touch;
- **fixed 9-touch designs**, analysed once as the fixed plan: ``3x3``, the square's centre,
  corners and edge mid-points (the widest 3 x 3 grid in the square explored); ``corners x2``,
  the centre and each corner twice (near the noise-optimal 9 for a 2-jet of positions and
  normals, which on a sphere puts all 9 at the corners: curvature from normals has variance
  ~ sigma_n^2 / sum r^2, from positions ~ sigma_p^2 / sum r^4, both largest there);
- **fixed 3 x 6**, the thesis's plan (18 touches).

Each cell is RMS S error (1) with, in brackets, its mean (the bias: an S bounded at +-1, as a
sphere's or a pit's, is underestimated in magnitude).  The last column is the best 9-touch
cell over the fixed 3 x 6 plan's RMS.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from bench_args import add_split, check_split, positive_int  # noqa: E402
from explore import (  # noqa: E402
    BUDGET,
    FLAT,
    HALF,
    SEED0,
    SPLITS,
    STANDOFF,
    build,
    rms,
    run_fixed,
    s_error,
    touch,
)

from tactile.explore import Explorer, Region, TouchPlan, fit_of  # noqa: E402

AFTER = (8, 9, 12, BUDGET)  # explore's touch counts reported
CORNERS = [(a, b) for a in (-1, 1) for b in (-1, 1)]
DESIGNS = {  # 9 touches each, in units of the half-size
    "3x3": [(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1)],
    "corners x2": [(0, 0)] + CORNERS + CORNERS,
}


def explore_errors(obj, spec, seed):
    """S error after each of ``AFTER``'s touch counts (None: no S then)."""
    rng = np.random.default_rng(seed)
    opts = {"noise_pos": spec[4], "noise_normal": spec[5]}
    ex = Explorer(Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), HALF, STANDOFF), max_touches=BUDGET,
                  flat=FLAT, options=opts)  # fmt: skip
    out = {}
    while ex.touches < BUDGET:
        plan = ex.plan()
        fit = ex.add(*touch(obj, plan, rng, spec[4], spec[5]), plan)
        if ex.touches in AFTER:
            out[ex.touches] = s_error(obj, fit.result)
    return out


def design_error(obj, spec, seed, design):
    """S error of one fixed design (straight down at each point), analysed once."""
    rng = np.random.default_rng(seed)
    pts, nrm = [], []
    for a, b in design:
        plan = TouchPlan((a * HALF, b * HALF, STANDOFF), (0.0, 0.0, -1.0), 2 * STANDOFF, None, "")
        p, n = touch(obj, plan, rng, spec[4], spec[5])
        if p is not None:
            pts.append(p)
            nrm.append(n)
    fit = fit_of(pts, nrm, flat=FLAT, noise_pos=spec[4], noise_normal=spec[5])
    return s_error(obj, fit.result)


def cell(errors):
    """'RMS (mean)' of the errors that exist, '-' for none."""
    v = [e for e in errors if e is not None]
    return "-" if not v else f"{rms(v):.4f} ({np.mean(v):+.4f})"


def table(split, seeds, only=None):
    heads = [f"explore after {n}" for n in AFTER] + [f"{d} (9)" for d in DESIGNS]
    print("| object | " + " | ".join(heads) + " | fixed 3x6 (18) | best 9 / fixed 3x6 |")
    print("|---|" + "---|" * (len(heads) + 2))
    for name, spec in SPLITS[split].items():
        if only and name not in only:
            continue
        obj, seeds_ = build(spec), [SEED0[split] + i for i in range(seeds)]
        ex = [explore_errors(obj, spec, s) for s in seeds_]
        cols = [[e.get(n) for e in ex] for n in AFTER]
        cols += [[design_error(obj, spec, s, d) for s in seeds_] for d in DESIGNS.values()]
        fixed = [run_fixed(obj, spec, s, FLAT)[2] for s in seeds_]
        nine = [rms([e for e in c if e is not None]) for c in cols[1:2] + cols[len(AFTER) :]]
        nine = [v for v in nine if v is not None]
        ratio = f"{min(nine) / rms(fixed):.2f}" if nine and rms(fixed) else "-"
        cells = [cell(c) for c in cols] + [cell(fixed), ratio]
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_split(ap, SPLITS)
    ap.add_argument("--seeds", type=positive_int, default=40,
                    help="runs per object and design (40; 20 move RMS S by 25 %%)")  # fmt: skip
    ap.add_argument("--only", nargs="*", help="these objects only")
    args = ap.parse_args()
    check_split(ap, args)
    t0 = time.process_time()
    table(args.split, args.seeds, args.only)
    print(f"\n({time.process_time() - t0:.0f} CPU s)")


if __name__ == "__main__":
    main()
