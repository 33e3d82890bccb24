"""EP2 speed: one 36-contact patch on an 8 x 8 grid in process, and the CLI on 1000 patches.

Run: .venv/bin/python bench/ep2_speed.py
Per-patch times of each configuration; the batched engine and its targets are a later
issue (the jet's per-patch Python costs most of these milliseconds).
"""

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from tactile.ep2 import analyze_patch, analyze_patches, batch_lstsq
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


def batched(n=512):
    """ms per patch: a loop of analyze_patch against analyze_patches at several chunk
    sizes, on the same n noisy patches, side by side in one run."""
    ds = [
        sweep(make("cylinder", 10.0, 30.0), noise_pos=0.01, noise_normal=0.01, seed=s)
        for s in range(n)
    ]
    pairs = [(d["points"], d["normals"]) for d in ds]
    t0 = time.perf_counter()
    for p, q in pairs:
        analyze_patch(p, q)
    loop = 1e3 * (time.perf_counter() - t0) / n
    print(f"\n| {n} patches | ms / patch | speed-up |\n|---|---|---|")
    print(f"| analyze_patch loop | {loop:.2f} | 1.0 |")
    for chunk in (16, 64, 256, 512):
        t0 = time.perf_counter()
        analyze_patches(pairs, chunk=chunk)
        ms = 1e3 * (time.perf_counter() - t0) / n
        print(f"| analyze_patches, chunk {chunk} | {ms:.2f} | {loop / ms:.1f} |")
    fast, batch_lstsq.FAST_MAX_COND = batch_lstsq.FAST_MAX_COND, 0.0  # the SVD for every fit
    t0 = time.perf_counter()
    analyze_patches(pairs, chunk=256)
    ms = 1e3 * (time.perf_counter() - t0) / n
    batch_lstsq.FAST_MAX_COND = fast
    print(
        f"| analyze_patches, chunk 256, SVD for every solve (before) | {ms:.2f} | {loop / ms:.1f} |"
    )


def main():
    d = sweep(make("cylinder", 10.0, 30.0), noise_pos=0.01, noise_normal=0.01, seed=1)
    print("| configuration | median ms / patch (36 contacts, 8x8 grid) |")
    print("|---|---|")
    for name, kw in CASES:
        print(f"| {name} | {median_ms(d, kw):.3f} |")
    batched()
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
