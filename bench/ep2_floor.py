"""EP2's arithmetic floor: what the default analysis's least-squares solves cost at best.

Issue 13 asks for ~20,000 patches/s on this 2-core machine, 100 us a patch a core.  This
bench counts the solves ``analyze_patches`` makes per patch (their sizes: rows used x
columns), their minimal arithmetic (Householder QR's R, 2 m p^2 - 2 p^3 / 3 flops each:
a lower bound, the estimator also builds rows, Jacobians and covariances), and prices it
at three rates measured here in one run, one core:

- this machine's peak: a large matrix product (BLAS dgemm), a bound no code reaches on
  10-column matrices;
- LAPACK one call per matrix (``np.linalg.qr`` on a stack of 108 x 10): what a compiled
  loop over LAPACK, or numba calling it, would get;
- ``batch_lstsq.solve`` on the same stack (CholeskyQR2, batched matmuls; it does about
  twice the minimal flops, counted here as the minimal ones);
- a hand-written C kernel (``ep2_floor_qr.c``, gcc -O3 -march=native, Householder with the
  stack innermost so each step runs across problems in SIMD lanes; its R checked against
  numpy's): what a compiled engine's solve could cost.  Skipped without gcc.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_floor.py [--n 256]
(from a checkout: PYTHONPATH=protocol:firmware:host:sim:studies:bench first).
"""

import argparse
import os
import shutil
import subprocess
import tempfile
import time
from collections import Counter

import numpy as np
from bench_args import positive_int
from timing import best_of

from tactile.ep2 import analyze_patches, batch_lstsq

TARGET = 20_000 / 2  # patches / s a core: the issue's ~20,000 / s on two cores


def qr_flops(m, p):
    """Minimal flops of Householder QR's R for an m x p problem (Golub & Van Loan 5.2.2)."""
    return 2.0 * m * p * p - 2.0 * p**3 / 3.0


def count_solves(pairs):
    """(problems a patch by column count, minimal QR flops a patch, ms a patch of the
    analysis) of ``analyze_patches`` on ``pairs``; the count is taken by wrapping
    ``batch_lstsq.solve`` (rows of weight 0, padding, are not counted)."""
    seen = []
    solve = batch_lstsq.solve

    def spy(A, b, w):
        m, p = A.shape[-2:]
        seen.append(((np.asarray(w).reshape(-1, m) > 0).sum(axis=1), p))
        return solve(A, b, w)

    batch_lstsq.solve = spy
    try:
        analyze_patches(pairs)
    finally:
        batch_lstsq.solve = solve
    n = len(pairs)
    by_p = Counter()
    for rows, p in seen:
        by_p[p] += len(rows) / n
    flops = sum(float(np.sum(qr_flops(rows, p))) for rows, p in seen) / n
    t0 = time.process_time()  # warmed by the counted run
    analyze_patches(pairs)
    return dict(sorted(by_p.items())), flops, 1e3 * (time.process_time() - t0) / n


def _cpu(fn):
    """CPU seconds of ``fn()``, best of 3 after a warm call."""
    return best_of(fn, clock=time.process_time, warm=True)[0]


def rates(batch=4096, m=108, p=10):
    """GFlop/s of one core: dgemm (n = 1500), LAPACK QR per matrix and ``batch_lstsq.solve``
    on a stack of ``batch`` m x p problems (minimal QR flops for both)."""
    rng = np.random.default_rng(0)
    big = rng.standard_normal((1500, 1500))
    peak = 2.0 * 1500**3 / _cpu(lambda: big @ big) / 1e9
    A = rng.standard_normal((batch, m, p))
    b, w = rng.standard_normal((batch, m)), np.ones((batch, m))
    work = batch * qr_flops(m, p) / 1e9
    lapack = work / _cpu(lambda: np.linalg.qr(A))  # Q and R: pinv, leverage need Q

    def chunks():
        for i in range(0, batch, 256):
            batch_lstsq.solve(A[i : i + 256], b[i : i + 256], w[i : i + 256])

    ours = work / _cpu(chunks)
    out = {"dgemm 1500 x 1500 (peak)": peak, "LAPACK QR (Q and R), one call a matrix": lapack,
            "batch_lstsq.solve, chunks of 256": ours}  # fmt: skip
    if shutil.which("gcc"):
        out["hand-written C, SIMD across 256 problems"] = c_kernel(A[:256], b[:256])
    return out


def c_kernel(A, b):
    """GFlop/s of ``ep2_floor_qr.c`` on the stack A (B, m, p), b (B, m) (minimal QR flops),
    its |R_kk| of the first problem checked against numpy's QR."""
    B, m, p = A.shape
    src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ep2_floor_qr.c")
    with tempfile.TemporaryDirectory() as tmp:
        exe = os.path.join(tmp, "qr")
        subprocess.run(["gcc", "-O3", "-march=native", "-o", exe, src, "-lm"], check=True)
        cols = np.moveaxis(A, 0, -1).transpose(1, 0, 2)  # (p, m, B): the kernel's layout
        data = " ".join(map(repr, [B, m, p, *cols.ravel().tolist(), *b.T.ravel().tolist()]))
        out = subprocess.run([exe], input=data, capture_output=True, text=True, check=True)
    seconds, *diag = map(float, out.stdout.split())
    want = np.abs(np.diagonal(np.linalg.qr(A[0], mode="r")))
    if not np.allclose(diag, want, rtol=1e-10):
        raise SystemExit(f"ep2_floor_qr.c: R differs from numpy's ({diag} against {want})")
    return B * qr_flops(m, p) / seconds / 1e9


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=positive_int, default=256, help="patches per scene (default 256)")
    args = ap.parse_args()
    from ep2_speed import SCENES

    speed = rates()
    budget = 1e6 / TARGET
    print("\n| one core, 108 x 10 problems | GFlop/s (minimal QR flops) |")
    print("|---|---|")
    for name, gf in speed.items():
        print(f"| {name} | {gf:.2f} |")
    print(f"\nbudget for ~20,000 patches / s on two cores: {budget:.0f} us a patch a core")
    print("\n| scene | solves / patch (by columns) | QR MFlop / patch | analysis ms / patch |"
          " solves alone at each rate (us / patch) |")  # fmt: skip
    print("|---|---|---|---|---|")
    for scene in ("cylinders", "round"):
        pairs = [(d["points"], d["normals"]) for d in (SCENES[scene](s) for s in range(args.n))]
        by_p, flops, ms = count_solves(pairs)
        total = sum(by_p.values())
        parts = ", ".join(f"{v:.1f} x {k}" for k, v in by_p.items())
        at = ", ".join(f"{1e6 * flops / (gf * 1e9):.0f}" for gf in speed.values())
        print(f"| {scene} | {total:.1f} ({parts}) | {flops / 1e6:.2f} | {ms:.2f} | {at} |")


if __name__ == "__main__":
    main()
