"""EP2's breakdown point: the default (and the 2-jet) with 0 to 6 gross outliers per patch.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_breakdown.py [--per-family 8]
     [--trials 3] [--max 6] [--out table.md]

The cases are the ``robust_tune`` split's (``tactile_studies.ep2.families``) of the sweep,
grid and scatter layouts (20-50 contacts), with their outliers replaced by k of them at
random contacts, of random kinds (a flipped normal, a point 0.1-0.3 L off the surface, a
contact on another face), for k = 0 .. ``--max``.  Per k and estimator: the share
answered, the outliers named (of those planted), contacts named that were no outlier, the
RMS S error, and the RMS S error of the same patches with the outliers taken out (the
bench's ``RMS S err / w/o outliers``).  The default is built to leave out at most 2
(``local_jet.MAX_OUTLIERS``): beyond that it should refuse ("more than 2 contacts
disagree"), not answer wrongly.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ep2_families  # noqa: E402
from bench_args import positive_int  # noqa: E402

from tactile_studies.ep2 import families, family_score  # noqa: E402

LAYOUTS = ("sweep", "grid", "scatter")


def cases_with(k, per_family, seed=0):
    """The robust_tune cases of ``LAYOUTS`` (``per_family`` each) with k outliers each."""
    rng = np.random.default_rng(seed + k)
    out = []
    for fam in families.FAMILIES:
        picked = [
            c for c in families.split("robust_tune") if c.family == fam and c.layout in LAYOUTS
        ]
        for c in picked[:per_family]:
            idx = sorted(rng.choice(c.n, size=min(k, c.n - 6), replace=False).tolist())
            kinds = rng.choice(families.OUTLIER_KINDS, size=len(idx))
            out.append(
                dataclasses.replace(c, outliers=tuple(zip(idx, map(str, kinds), strict=True)))
            )
    return out


def table(per_family, trials, k_max):
    head = ["outliers", "estimator", *family_score.HEAD, *family_score.ROBUST_HEAD]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for k in range(k_max + 1):
        by_est, _, _ = ep2_families.run(
            "robust_tune", ["default", "jet2"], trials, repeats=1, cases=cases_with(k, per_family)
        )
        for name, recs in by_est.items():
            lines.append("| " + " | ".join([str(k), name, *family_score.cells(recs, True)]) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-family", type=positive_int, default=8)
    ap.add_argument("--trials", type=positive_int, default=3)
    ap.add_argument("--max", type=positive_int, default=6)
    ap.add_argument("--out")
    args = ap.parse_args(argv)
    text = table(args.per_family, args.trials, args.max)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
