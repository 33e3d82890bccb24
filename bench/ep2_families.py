"""EP2 estimators side by side on the surface families (``tactile_studies.ep2.families``).

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_families.py --split tune
     [--estimators default,jet2[,spline]] [--trials 5] [--per-family N] [--families a,b]
     [--repeats 3] [--out table.md]

``--split holdout`` and ``--split robust_holdout`` are FOR FINAL EVALUATION ONLY, refused
without ``--final`` (``families`` module docstring).  Estimators (``ESTIMATORS``, or
``module:function`` taking a list of patch dicts and returning a result or an exception per patch):

- ``default``: ``tactile.ep2.analyze_patches`` as it is when run, in one call (each patch
  dict with its noise where the case states it), in a process whose allocator keeps its
  freed heap (``batch.keep_heap``), as ``tactile ep2 analyze``'s is (every estimator shares it);
- ``jet2``: the batched numpy 2-jet with normals (``tactile_studies.ep2.jet2``);
- ``spline``: ``analyze_patches(method="spline")``, in one call as ``default``;
- ``jet2_positions``: the quadric jet of the heights alone (``jet2.positions``);
- ``fitpack``: scipy's bicubic smoothing spline of the heights (``fitpack_peer``).

Every estimator gets the same draws.  A noise-free case without outliers is drawn once, any
other ``--trials`` times.  In the robust splits each estimator also gets each patch without
its outliers (untimed) for the last column.  Timing: CPU seconds (``time.process_time``)
per patch of each estimator's whole run over the split's patches, best of ``--repeats``,
the estimators in turn in one process (OPENBLAS_NUM_THREADS=1).  Tables
(``family_score``): refusal reasons, then per family, per noise bin, per layout, per |k|max L
bin (at the case's centre point), per family x |k| L, then family x noise bin x layout.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_args import add_split, check_split, positive_int  # noqa: E402

from tactile.ep2 import analyze_patches  # noqa: E402
from tactile.ep2.batch import keep_heap  # noqa: E402
from tactile_studies.ep2 import families, family_score, fitpack_peer, jet2  # noqa: E402

DEFAULT_TRIALS = 5


def _library(patches, **kw):
    """``analyze_patches`` in one call, each patch with its noise where ``stated``."""
    todo = []
    for d in patches:
        p = {k: d[k] for k in ("points", "normals", "finger")}
        if d["stated"]:
            p.update(noise_pos=d["noise_pos"], noise_normal=d["noise_normal"])
        todo.append(p)
    return analyze_patches(todo, **kw)


def default(patches):
    return _library(patches)


def spline(patches):
    return _library(patches, method="spline")


ESTIMATORS = {
    "default": default,
    "jet2": jet2.analyze,
    "jet2_positions": jet2.positions,
    "fitpack": lambda patches: fitpack_peer.analyze(patches),
    "spline": spline,
}


def resolve(spec):
    if spec in ESTIMATORS:
        return ESTIMATORS[spec]
    module, _, name = spec.partition(":")
    if not name:
        raise SystemExit(f"estimator {spec!r}: use {', '.join(ESTIMATORS)} or module:function")
    return getattr(importlib.import_module(module), name)


def select(split, per_family=None, only=None, cases=None):
    """The split's cases (``per_family`` of each, ``only`` these families; or ``cases`` as
    given), ``well_posed`` set."""
    if cases is None:
        cases = families.split(split, per_family)
    if only:
        cases = [c for c in cases if c.family in only]
    posed = family_score.well_posed(cases)
    return [dataclasses.replace(c, well_posed=bool(p)) for c, p in zip(cases, posed)]


def draws(cases, trials):
    """[(case, [draw, ...])], and the flat list of patches (and their outlier-free twins)."""
    out, flat, clean = [], [], []
    for c in cases:
        ds = [families.draw(c, t) for t in range(c.trials_needed or trials)]
        out.append((c, ds))
        for d in ds:
            flat.append(d)
            keep = d["inliers"]
            clean.append(
                dict(d, points=d["points"][keep], normals=d["normals"][keep],
                     finger=d["finger"][keep])
            )  # fmt: skip
    return out, flat, clean


def timed(fn, patches, repeats):
    """(results of the first run, best CPU seconds of ``repeats`` runs)."""
    best, results = float("inf"), None
    for _ in range(repeats):
        t0 = time.process_time()
        res = fn(patches)
        best = min(best, time.process_time() - t0)
        results = res if results is None else results
    return results, best


def run(split, names, trials=DEFAULT_TRIALS, per_family=None, only=None, repeats=3, cases=None):
    """(records per estimator, timing rows, number of cases): the whole bench, no printing
    (``cases``: these instead of the split's)."""
    cases = select(split, per_family, only, cases)
    per_case, flat, clean = draws(cases, trials)
    robust = any(c.outliers for c in cases)
    by_est, timing = {}, []
    for name in names:
        fn = resolve(name)
        results, cpu = timed(fn, flat, repeats)
        clean_results = fn(clean) if robust else None
        recs, k = [], 0
        for case, ds in per_case:
            part = results[k : k + len(ds)]
            cpart = clean_results[k : k + len(ds)] if robust else None
            recs += family_score.records(case, ds, part, cpart)
            k += len(ds)
        by_est[name] = recs
        timing.append((name, len(flat), cpu))
    return by_est, timing, len(cases)


def report(by_est, timing, head, robust):
    """The markdown: head line, timing, per family / noise / layout, then the full table."""
    rows = ["| estimator | patches | CPU s / patch (best of repeats) | CPU s, whole run |",
            "|---|---|---|---|"]  # fmt: skip
    rows += [f"| {n} | {m} | {cpu / max(m, 1):.2e} | {cpu:.2f} |" for n, m, cpu in timing]
    parts = [head, "", *rows, "", "Refusals:", "", family_score.reasons(by_est)]
    tables = (("family",), ("noise",), ("layout",), ("kl",), ("family", "kl"))
    for keys in (*tables, ("family", "noise", "layout")):
        parts += ["", f"By {' x '.join(keys)}:", "", family_score.table(by_est, keys, robust)]
    return "\n".join(parts)


def _parser():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_split(ap, families.SPLITS)
    ap.add_argument("--estimators", default="default,jet2", help="comma-separated")
    ap.add_argument("--trials", type=positive_int, default=DEFAULT_TRIALS)
    ap.add_argument("--per-family", type=positive_int, help="cases per family (default all)")
    ap.add_argument("--families", help="comma-separated subset of families.FAMILIES")
    ap.add_argument("--repeats", type=positive_int, default=3, help="timing: best of these")
    ap.add_argument("--out", help="also write the markdown here")
    return ap


def main(argv=None):
    keep_heap()  # (as the CLI: the allocator keeps the stacks' pages)
    ap = _parser()
    args = ap.parse_args(argv)
    check_split(ap, args)
    names = [n for n in args.estimators.split(",") if n]
    for n in names:
        resolve(n)
    only = args.families.split(",") if args.families else None
    t0 = time.perf_counter()
    by_est, timing, n_cases = run(
        args.split, names, args.trials, args.per_family, only, args.repeats
    )
    wall = time.perf_counter() - t0
    robust = args.split.startswith("robust")
    head = (
        f"split {args.split}, {n_cases} cases, {args.trials} trials per case (1 when"
        f" noise-free without outliers), estimators {', '.join(names)}; {wall:.1f} s wall"
        f" in all (timing best of {args.repeats}, OPENBLAS_NUM_THREADS="
        f"{os.environ.get('OPENBLAS_NUM_THREADS')})"
    )
    text = report(by_est, timing, head, robust)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
