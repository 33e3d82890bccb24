"""EP2 CLI at scale (issue 13): grouping of scattered rows, reading, and `ep2 analyze` wall.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_cli_scale.py [--quick]
(from a checkout: PYTHONPATH=protocol:firmware:host:sim first)
Files of 36-contact patches whose rows are scattered through the file (each patch's rows
spread over a window of 100 patches).  Prints the grouping time for 1k/10k/100k patches and
its 10k->100k ratio (10 is linear), the reading time of the CSV, and the CLI's wall and
peak RSS for 1k and 10k patches with --jobs 1 and 2 (the CLI runs first: a child
forked from a large bench would inherit its peak RSS).  The estimator is still called once
per patch (the batched engine of issue 13 is not written), so the CLI's wall is that
per-patch cost divided by the jobs.
"""

import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from tactile.ep2.contacts_csv import group_rows, read_contacts
from tactile_sim.ep2 import make, sweep

ROWS = 36
WINDOW = 100  # patches whose rows are interleaved


def scattered_ids(n_patches, seed=0):
    """Patch ids (text, as the CSV has them) of every row, rows of a patch scattered."""
    rng = np.random.default_rng(seed)
    ids = np.repeat(np.arange(n_patches), ROWS)
    for start in range(0, ids.size, WINDOW * ROWS):
        block = ids[start : start + WINDOW * ROWS]
        block[:] = block[rng.permutation(block.size)]
    return [str(v) for v in ids]


def old_grouping(ids):
    """What read_contacts did before issue 13: one scan of the file per patch."""
    return [[i for i, p in enumerate(ids) if p == name] for name in dict.fromkeys(ids)]


def best_of(fn, arg, n=3):
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn(arg)
        ts.append(time.perf_counter() - t0)
    return min(ts)


def write_csv(path, n_patches):
    bases = [
        sweep(make(kind, 8.0), noise_pos=0.01, noise_normal=0.01, seed=s)
        for s, kind in enumerate(("sphere", "cylinder", "saddle", "pit") * 5)
    ]
    text = [
        [",".join(f"{v:.8g}" for v in (*p, *n)) + f",{int(f)}" for p, n, f in zip(*b)]
        for b in ((d["points"], d["normals"], d["finger"]) for d in bases)
    ]
    pos = np.zeros(n_patches, int)
    with open(path, "w") as fh:
        fh.write("x,y,z,nx,ny,nz,finger,patch\n")
        for pid in scattered_ids(n_patches):
            i = int(pid)
            fh.write(f"{text[i % len(text)][pos[i]]},{pid}\n")
            pos[i] += 1


def main():
    quick = "--quick" in sys.argv
    sizes = (1_000, 10_000) if quick else (1_000, 10_000, 100_000)
    tactile = [sys.executable, "-m", "tactile.cli.main"]  # the sources on PYTHONPATH
    print(
        "\n| patches | read_contacts (s) | jobs | `ep2 analyze` wall (s) | patches/s"
        " | peak RSS (MB) |"
    )
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in (1_000, 10_000):
            path = os.path.join(tmp, f"p{n}.csv")
            write_csv(path, n)
            rows = []
            for jobs in (1, 2):
                t0 = time.perf_counter()
                run = subprocess.run(
                    [*tactile, "ep2", "analyze", path, "--json", "--jobs", str(jobs)],
                    capture_output=True,
                )
                wall = time.perf_counter() - t0
                assert run.returncode in (0, 3), run.stderr
                assert run.stdout.count(b"\n") == n
                rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
                rows.append(f"{jobs} | {wall:.1f} | {n / wall:.0f} | {rss:.0f} |")
            read = best_of(read_contacts, path, 1)  # after the CLI: see the docstring
            for row in rows:
                print(f"| {n:,} | {read:.2f} | {row}")
    print()
    print("| patches | rows | grouping (s) | previous grouping (s) |")
    print("|---|---|---|---|")
    times = {}
    for n in sizes:
        ids = scattered_ids(n)
        times[n] = best_of(group_rows, ids)
        old = f"{best_of(old_grouping, ids, 1):.2f}" if n <= 1_000 else "(quadratic: skipped)"
        print(f"| {n:,} | {len(ids):,} | {times[n]:.3f} | {old} |")
    if 100_000 in times:
        print(
            f"\ngrouping 10k -> 100k patches: x{times[100_000] / times[10_000]:.1f} (10 = linear)"
        )


if __name__ == "__main__":
    main()
