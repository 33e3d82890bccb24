"""EP2 batch cost of several git revisions side by side: which change cost or saved what.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_revisions.py [--scene cylinders|round]
[--n 512] [--rounds 6] [REV ...]   (``.`` is this working tree; default ``. HEAD``; from a
checkout: PYTHONPATH=protocol:firmware:host:sim:studies first).

Each revision's host library (``git archive``) runs ``analyze_patches`` (chunk 256) on the
same patches (``ep2_speed.SCENES``) in its own child process (``ep2_speed``'s): warmed by a first
call, then the best of 3 in CPU time.  The revisions take turns, ``--rounds`` times, and each one's
median over the rounds is printed with its range and its ratio to the first revision: on
this shared 2-core machine one run of one revision moves by 20-30 %, so single runs do not
rank changes of that size (docs/ep2.md, "What the trust work cost").
"""

import argparse
import os
import tempfile

import numpy as np
from ep2_speed import SCENES, _export, _theirs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("revs", nargs="*", default=[".", "HEAD"], help="git revisions; . is this tree")
    ap.add_argument("--scene", choices=sorted(SCENES), default="cylinders")
    ap.add_argument("--n", type=int, default=512, help="patches")
    ap.add_argument("--rounds", type=int, default=6, help="turns per revision")
    args = ap.parse_args()
    ds = [SCENES[args.scene](s) for s in range(args.n)]
    times = {rev: [] for rev in args.revs}
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "patches.npz")
        np.savez(data, points=np.array([d["points"] for d in ds]),
                 normals=np.array([d["normals"] for d in ds]))  # fmt: skip
        hosts = {}
        for k, rev in enumerate(args.revs):
            os.makedirs(os.path.join(tmp, str(k)))
            hosts[rev] = _export(rev, os.path.join(tmp, str(k)))
        for _ in range(args.rounds):
            for rev in args.revs:
                times[rev].append(_theirs(hosts[rev], data, "cpu"))
    first = float(np.median(times[args.revs[0]]))
    print(f"\n| {args.n} patches ({args.scene}), {args.rounds} rounds | median CPU ms / patch"
          f" | range | vs {args.revs[0]} |")  # fmt: skip
    print("|---|---|---|---|")
    for rev in args.revs:
        t = np.array(times[rev])
        med = float(np.median(t))
        print(f"| {rev} | {med:.3f} | {t.min():.3f}-{t.max():.3f} | {med / first:.2f} |")


if __name__ == "__main__":
    main()
