"""EP2 speed: one 36-contact patch on an 8 x 8 grid in process, the batched engine against
the per-patch loop, and the CLI on 1000 patches.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_speed.py [--n 512] [--against REV]
[--batch-only | --fit-only | --options] [--scene cylinders|round]   (from a checkout:
PYTHONPATH=protocol:firmware:host:sim:studies first).  ``--fit-only`` times the batched
tangent fit alone (``tangent_fit``); ``--options`` the batch with parts of the default
analysis switched off (``OPTIONS``), taking turns, against the default.
``--against REV`` also times git revision REV's ``analyze_patch`` loop and
``analyze_patches`` on the same patches, in a child process that imports REV's host
library (``git archive``), alternating with this tree's runs: before and after side by
side in one run (best of ``REPEATS``; compare the ratios, the machine is shared).
``--scene round`` batches low-noise spheres and cylinders, where the round model is
chosen (its truncation view fits a round 4-jet).  ``--batch-only`` skips the one-patch
configurations and the CLI; with ``--fit-only``,
``--against REV`` times REV's host library on the same tangent fit (this bench's code).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
from bench_args import positive_int

from tactile.ep2 import analyze_patch, analyze_patches, batch_lstsq, jet_basis, jet_frames, jet_rows
from tactile_sim.ep2 import make, sweep

CASES = (
    ("default (jet: noise estimated, round/quadric chosen, intervals)", {}),
    ("noise stated", {"noise_pos": 0.01, "noise_normal": 0.01}),
    ("no intervals", {"intervals": False}),
    ("maps kept", {"maps": True}),
    ("spline deg 2 auto (previous default)", {"method": "spline"}),
    ("spline deg 3 tangent (thesis)", {"method": "spline", "order": 3, "weighting": "tangent"}),
    ("spline deg 2 auto, align refit (§4.10)", {"method": "spline", "align": True}),
)


def median_ms(d, kw, n=400):
    analyze_patch(d["points"], d["normals"], **kw)
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        analyze_patch(d["points"], d["normals"], **kw)
        ts.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(ts))


REPEATS = 3  # best of, each configuration, alternating this tree and --against
CHUNKS = (16, 64, 256, 512)
_CHILD = """
import json, sys, time
import numpy as np
from tactile.ep2 import analyze_patch, analyze_patches
z = np.load(sys.argv[1])
pairs = list(zip(z["points"], z["normals"]))
what = sys.argv[2]
if what != "fit":  # warm, as this tree is warmed: imports and caches of the first call
    analyze_patches(pairs[:16])
t0 = time.perf_counter()
if what == "fit":  # this tree's bench, REV's host library: tangent fit patches / s
    sys.path.insert(0, sys.argv[3])
    from ep2_speed import fit_chunks
    print(json.dumps(fit_chunks(z["points"], z["normals"])[1]))
    sys.exit()
if what == "cpu":  # ep2_revisions.py: CPU, best of 3, chunk 256
    best = float("inf")
    for _ in range(3):
        t0 = time.process_time()
        analyze_patches(pairs, chunk=256)
        best = min(best, time.process_time() - t0)
    print(json.dumps(1e3 * best / len(pairs)))
    sys.exit()
if what == "loop":
    for p, q in pairs:
        analyze_patch(p, q)
else:
    analyze_patches(pairs, chunk=int(what))
print(json.dumps(1e3 * (time.perf_counter() - t0) / len(pairs)))
"""


def _this(pairs, what):
    """ms per patch of this tree: the analyze_patch loop or analyze_patches at a chunk."""
    t0 = time.perf_counter()
    if what == "loop":
        for p, q in pairs:
            analyze_patch(p, q)
    else:
        analyze_patches(pairs, chunk=int(what))
    return 1e3 * (time.perf_counter() - t0) / len(pairs)


def _export(rev, into):
    """REV's host library, as ``git archive`` gives it, under ``into``/host (``.``: this
    working tree's)."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if rev == ".":
        shutil.copytree(os.path.join(here, "host"), os.path.join(into, "host"))
        return os.path.join(into, "host")
    tar = subprocess.run(
        ["git", "-C", here, "archive", rev, "host"], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", into], input=tar, check=True)
    return os.path.join(into, "host")


def _theirs(host, data, what):
    """ms per patch of the exported revision (a child process, warmed by a first call as
    this tree is; its import time excluded)."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paths = [host] + [os.path.join(here, d) for d in ("protocol", "firmware", "sim")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(paths))
    args = [sys.executable, "-c", _CHILD, data, what, os.path.join(here, "bench")]
    out = subprocess.run(args, env=env, check=True, capture_output=True)
    return json.loads(out.stdout)


SCENES = {  # --scene: which model the data choose
    "cylinders": lambda s: sweep(  # noisy R 10 cylinders: the quadric (2-jet) chosen
        make("cylinder", 10.0, 30.0), noise_pos=0.01, noise_normal=0.01, seed=s
    ),
    "round": lambda s: sweep(  # R 8 spheres and cylinders at noise 5e-4: the round model
        make(("sphere", "cylinder")[s % 2], 8.0), noise_pos=5e-4, noise_normal=5e-4, seed=s
    ),
}


def batched(n=512, against=None, scene="cylinders"):
    """ms per patch: a loop of analyze_patch against analyze_patches at several chunk
    sizes, on the same n noisy patches, side by side in one run; with ``against`` (a git
    revision) the same for that revision, alternating with this tree's runs."""
    ds = [SCENES[scene](s) for s in range(n)]
    pairs = [(d["points"], d["normals"]) for d in ds]
    configs = ["loop", *map(str, CHUNKS)]
    best = {}
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "patches.npz")
        np.savez(data, points=np.array([p for p, _ in pairs]), normals=[q for _, q in pairs])
        host = _export(against, tmp) if against else None
        analyze_patches(pairs[:16])  # warm: imports, caches
        turns = []  # each turn's loop / chunk-256 ratio: the run's own spread
        for _ in range(REPEATS):
            turn = {}
            for what in configs:
                turn[what] = _this(pairs, what)
                best[what] = min(best.get(what, np.inf), turn[what])
                if host and what in ("loop", "256"):
                    key = (against, what)
                    best[key] = min(best.get(key, np.inf), _theirs(host, data, what))
            turns.append(turn["loop"] / turn["256"])
    loop = best["loop"]
    print(f"\n| {n} patches | ms / patch | patches / s | vs this loop |")
    print("|---|---|---|---|")
    rows = [("analyze_patch loop", loop)]
    rows += [(f"analyze_patches, chunk {c}", best[str(c)]) for c in CHUNKS]
    if against:
        rows += [
            (f"{against}: analyze_patch loop", best[(against, "loop")]),
            (f"{against}: analyze_patches, chunk 256", best[(against, "256")]),
        ]
    for name, ms in rows:
        print(f"| {name} | {ms:.2f} | {1e3 / ms:.0f} | {loop / ms:.1f} |")
    print("\nloop / chunk 256, each turn: " + ", ".join(f"{r:.1f}x" for r in turns))
    if against:
        old_loop = best[(against, "loop")]
        print(
            f"\nanalyze_patches chunk 256: {old_loop / best['256']:.1f} x {against}'s loop,"
            f" {best[(against, '256')] / best['256']:.2f} x {against}'s analyze_patches"
        )
    fast, batch_lstsq.FAST_MAX_COND = batch_lstsq.FAST_MAX_COND, 0.0  # the SVD for every fit
    ms = _this(pairs, "256")
    batch_lstsq.FAST_MAX_COND = fast
    print(f"\nanalyze_patches, chunk 256, the SVD for every solve: {ms:.2f} ms / patch")


OPTIONS = (  # --options: what switching a part of the default analysis off saves
    ("default", {}),
    ("intervals=False (no truncation views)", {"intervals": False}),
    ("noise stated (no noise estimate)", {"noise_pos": 0.01, "noise_normal": 0.01}),
    ("both", {"intervals": False, "noise_pos": 0.01, "noise_normal": 0.01}),
)


def options_cost(n=512, scene="cylinders", rounds=5):
    """CPU ms per patch of ``analyze_patches`` (chunk 256) with each of ``OPTIONS``, taking
    turns ``rounds`` times on the same patches; medians and the ratio to the default."""
    pairs = [(d["points"], d["normals"]) for d in (SCENES[scene](s) for s in range(n))]
    analyze_patches(pairs[:32])  # warm
    times = {name: [] for name, _ in OPTIONS}
    for _ in range(rounds):
        for name, kw in OPTIONS:
            t0 = time.process_time()
            analyze_patches(pairs, **kw)
            times[name].append(1e3 * (time.process_time() - t0) / n)
    base = np.median(times["default"])
    print(f"\n| {n} patches ({scene}), {rounds} turns | median CPU ms / patch | vs default |")
    print("|---|---|---|")
    for name, _ in OPTIONS:
        ms = np.median(times[name])
        print(f"| {name} | {ms:.2f} | {ms / base:.2f} |")


def tangent_fit(points, normals, sigma):
    """The batched tangent fit alone (issue 13's 30,000 patches/s figure): each patch in its
    mean-normal frame, the 3-jet fitted to positions and slopes whitened per contact with
    the stated noise ``sigma`` = (position, normal), a second pass whitened by the first
    fit's geometry; k1 >= k2 (B, 2) from the Hessian at the centre.  No noise estimate,
    model choice, checks or intervals: the kernel the default analysis calls ~38 times."""
    B, n = points.shape[:2]
    mask = np.ones((B, n), bool)
    origin, M = jet_frames.mean_frame(points, normals, mask, [None] * B)
    p = np.einsum("bij,bnj->bni", M, points - origin[:, None, :])
    nrm = np.einsum("bij,bnj->bni", M, normals)
    sig = np.broadcast_to(np.asarray(sigma, float), (B, 2))
    geo = None
    for _ in range(2):
        rows = jet_rows.make(p, nrm, mask, sig, geo)
        coef = batch_lstsq.solve(rows.A, rows.b, rows.w).coef
        geo = jet_rows.geometry(rows, coef)
    return np.linalg.eigvalsh(-jet_basis.hessian(coef))[:, ::-1]  # z along the outward normal


def fit_chunks(P, N):
    """(k1, k2 of every patch, seconds) of ``tangent_fit`` over P, N in chunks of 256."""
    t0 = time.perf_counter()
    k = [tangent_fit(P[i : i + 256], N[i : i + 256], (0.01, 0.01)) for i in range(0, len(P), 256)]
    return np.concatenate(k), time.perf_counter() - t0


def tangent_fit_speed(n=4096, against=None):
    """patches/s of ``tangent_fit`` in chunks of 256, beside analyze_patches (default) on
    the first 256 of the same patches; its curvatures against the truth (R = 10); with
    ``against`` (a git revision) the same fit on that revision's host library, alternating."""
    ds = [
        sweep(make("cylinder", 10.0, 30.0), noise_pos=0.01, noise_normal=0.01, seed=s)
        for s in range(n)
    ]
    P = np.array([d["points"] for d in ds])
    N = np.array([d["normals"] for d in ds])
    k = None
    best, theirs = np.inf, np.inf
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "patches.npz")
        np.savez(data, points=P, normals=N)
        host = _export(against, tmp) if against else None
        fit_chunks(P[:256], N[:256])  # warm
        for _ in range(REPEATS):
            k, t = fit_chunks(P, N)
            best = min(best, t)
            if host:
                theirs = min(theirs, _theirs(host, data, "fit"))
    t0 = time.perf_counter()
    analyze_patches([(P[i], N[i]) for i in range(256)])
    full = (time.perf_counter() - t0) / 256
    print(f"\n| {n} patches, chunks of 256 | patches / s | us / patch |")
    print("|---|---|---|")
    print(
        f"| tangent fit alone (two passes, noise stated) | {n / best:,.0f} | {1e6 * best / n:.1f} |"
    )
    if against:
        print(f"| {against}: tangent fit alone | {n / theirs:,.0f} | {1e6 * theirs / n:.1f} |")
    print(f"| analyze_patches (default analysis) | {1 / full:,.0f} | {1e6 * full:.1f} |")
    if against:
        print(f"\ntangent fit alone: {theirs / best:.2f} x {against}'s")
    err, k2 = np.median(np.abs(k[:, 0] - 0.1)) / 0.1, np.median(k[:, 1])
    print(f"\ntangent fit alone: median |k1 - 1/R| / (1/R) = {err:.4f} (k2 median {k2:.2g})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=positive_int, default=512, help="patches, batched comparison")
    ap.add_argument("--against", help="a git revision to time side by side (e.g. main)")
    ap.add_argument("--batch-only", action="store_true", help="only the batched comparison")
    ap.add_argument("--fit-only", action="store_true", help="only the tangent fit alone")
    ap.add_argument("--scene", choices=sorted(SCENES), default="cylinders", help="the patches")
    ap.add_argument("--options", action="store_true", help="only the cost of each option")
    args = ap.parse_args()
    if args.options:
        options_cost(args.n, args.scene)
        return
    if args.fit_only:
        tangent_fit_speed(against=args.against)
        return
    if not args.batch_only:
        d = sweep(make("cylinder", 10.0, 30.0), noise_pos=0.01, noise_normal=0.01, seed=1)
        print("| configuration | median ms / patch (36 contacts, 8x8 grid) |")
        print("|---|---|")
        for name, kw in CASES:
            print(f"| {name} | {median_ms(d, kw):.3f} |")
    batched(args.n, args.against, args.scene)
    if args.batch_only:
        return
    tactile = os.path.join(os.path.dirname(sys.executable), "tactile")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "p1000.csv")
        subprocess.run(
            [
                tactile,
                "sim",
                "ep2",
                "--object",
                "sphere",
                "--patches",
                "1000",
                "--noise-pos",
                "0.01",
                "--noise-normal",
                "0.01",
                "-o",
                path,
            ],
            check=True,
            capture_output=True,
        )
        for extra in ([], ["--json"]):
            t0 = time.perf_counter()
            subprocess.run(
                [tactile, "ep2", "analyze", path, *extra], check=True, capture_output=True
            )
            wall = time.perf_counter() - t0
            print(f"\n`tactile ep2 analyze` 1000 patches {' '.join(extra)}: {wall:.2f} s wall")


if __name__ == "__main__":
    main()
