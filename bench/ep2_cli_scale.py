"""EP2 CLI at scale (issue 13): grouping, the streamed reader and `ep2 analyze`, wall and
peak RSS, from 1,000 to 1,000,000 patches.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_cli_scale.py [--quick]
[--cli-max N] [--long S] [--jobs 1,2] [--only SECTIONS]   (from a checkout:
PYTHONPATH=protocol:firmware:host:sim:studies first; the files go to $TMPDIR, 2.7 GB for
1M patches; --quick stops at 10k patches).

Files of 36-contact patches whose rows are scattered through the file (each patch's rows
spread over a window of 100 patches).  Every figure but grouping comes from a child
process, so it is what a user of the CLI sees: wall, and peak RSS as the largest VmHWM of
the process and its workers (sampled from /proc; a forked worker counts the pages it
shares with the parent, so this is the largest single process, not a sum).

1. Grouping ids in one pass (``group_rows``): 1k/10k/100k patches, ratio 10k -> 100k.
2. The reader alone (``ContactsFile``: the checking pass, then every patch read again and
   given out): 10k, 100k and 1M patches, wall and peak RSS.
3. ``tactile ep2 analyze --json``: 1k and 10k patches with --jobs 1 and 2, 100k with
   --jobs 2 (``--jobs``: every size with those counts), the 10k -> 100k ratios, and the
   1M-patch file for a bounded time (``--long`` seconds after its first record: peak RSS
   while it runs; the whole run would take over an hour at today's estimator cost).  Wall
   and CPU seconds both: on a shared machine the CPU ratio is the steadier measure of
   linearity.
"""

import functools
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
from timing import best_of, peak_rss_mb

from tactile.ep2.contacts_csv import group_rows
from tactile_sim.ep2 import make, sweep

ROWS = 36
WINDOW = 100  # patches whose rows are interleaved
LONG_S = 120  # seconds of analysis of the 1M-patch file
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = [os.path.join(HERE, "..", d) for d in ("protocol", "firmware", "host", "sim", "studies")]
ENV = {
    **os.environ,
    "PYTHONPATH": os.pathsep.join(filter(None, [*SOURCES, os.environ.get("PYTHONPATH")])),
    "OPENBLAS_NUM_THREADS": "1",
}
READER = (
    "import sys; from tactile.ep2.contacts_csv import ContactsFile;"
    " f = ContactsFile(sys.argv[1]); print(len(f), sum(len(g.lines) for g in f))"
)


def scattered_ids(n_patches, seed=0):
    """Patch ids (integers) of every row, each window of patches shuffled together."""
    rng = np.random.default_rng(seed)
    ids = np.repeat(np.arange(n_patches), ROWS)
    for start in range(0, ids.size, WINDOW * ROWS):
        block = ids[start : start + WINDOW * ROWS]
        block[:] = block[rng.permutation(block.size)]
    return ids


def write_csv(path, n_patches):
    """Scattered 36-contact patches of 20 noisy sweeps, written a window at a time."""
    bases = [
        sweep(make(kind, 8.0), noise_pos=0.01, noise_normal=0.01, seed=s)
        for s, kind in enumerate(("sphere", "cylinder", "saddle", "pit") * 5)
    ]
    text = [
        [",".join(f"{v:.8g}" for v in (*p, *n)) + f",{int(f)}," for p, n, f in zip(*b)]
        for b in ((d["points"], d["normals"], d["finger"]) for d in bases)
    ]
    with open(path, "w") as fh:
        fh.write("x,y,z,nx,ny,nz,finger,patch\n")
        for start in range(0, n_patches, WINDOW):
            stop = min(start + WINDOW, n_patches)
            ids = scattered_ids(stop - start, seed=start) + start
            pos = np.zeros(stop - start, int)
            lines = []
            for i in ids.tolist():
                lines.append(f"{text[i % len(text)][pos[i - start]]}{i}\n")
                pos[i - start] += 1
            fh.write("".join(lines))


def cpu_s():
    """CPU seconds of the children waited for so far (and of their workers)."""
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def measure(cmd, stop_after=None):
    """(wall s, CPU s, peak RSS MB, stdout lines, exit code, s to the first line) of
    ``cmd``; with ``stop_after``, Ctrl-C it that many seconds after its first line (the
    lines counted up to then).  A thread drains stdout as fast as it comes: read every
    0.2 s, the 64 KiB pipe held the CLI to about 130 patches/s."""
    cpu0, t0 = cpu_s(), time.perf_counter()
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=ENV, start_new_session=True
    )
    seen = {"lines": 0, "first": None, "stop": None}
    drain = threading.Thread(target=_drain, args=(proc.stdout, seen), daemon=True)
    drain.start()
    peak = 0
    while proc.poll() is None:
        peak = max(peak, peak_rss_mb(proc.pid))
        now = time.perf_counter()
        first, stop = seen["first"], seen["stop"]
        if stop is None and stop_after is not None and first and now - first > stop_after:
            seen["stop"] = now
            os.killpg(proc.pid, signal.SIGINT)  # the CLI's own Ctrl-C (workers ignore it)
        if stop is not None and now - stop > 60:
            os.killpg(proc.pid, signal.SIGKILL)
        time.sleep(0.2)
    drain.join()
    wall = time.perf_counter() - t0
    start = None if seen["first"] is None else seen["first"] - t0
    return wall, cpu_s() - cpu0, peak, seen["lines"], proc.returncode, start


def _drain(pipe, seen):
    """Count the lines of ``pipe`` until it closes (those before ``seen["stop"]``)."""
    for block in iter(lambda: pipe.read1(1 << 16), b""):
        if seen["stop"] is None:
            seen["lines"] += block.count(b"\n")
        if seen["first"] is None and seen["lines"]:
            seen["first"] = time.perf_counter()


def grouping(sizes):
    print("\n| patches | rows | grouping (s) |")
    print("|---|---|---|")
    times = {}
    for n in sizes:
        ids = [str(v) for v in scattered_ids(n)]
        times[n] = best_of(functools.partial(group_rows, ids))[0]
        print(f"| {n:,} | {len(ids):,} | {times[n]:.3f} |")
    if 100_000 in times:
        print(f"\ngrouping 10k -> 100k: x{times[100_000] / times[10_000]:.1f} (10 = linear)")


def reader(files):
    print("\n| patches | file (MiB) | reader wall (s) | CPU (s) | rows/s of CPU | peak RSS (MB) |")
    print("|---|---|---|---|---|---|")
    for n, path in files.items():
        wall, cpu, rss, _, code, _ = measure([sys.executable, "-c", READER, path])
        assert code == 0
        mib = os.path.getsize(path) / 2**20
        print(f"| {n:,} | {mib:,.0f} | {wall:.1f} | {cpu:.1f} | {n * ROWS / cpu:,.0f} | {rss} |")


def analyze(files, runs):
    print("\n| patches | jobs | `ep2 analyze` wall (s) | CPU (s) | patches/s | peak RSS (MB) |")
    print("|---|---|---|---|---|---|")
    walls = {}
    for n, jobs in runs:
        wall, cpu, rss, lines, code, _ = measure([*CLI, files[n], "--jobs", str(jobs)])
        assert code in (0, 3) and lines == n, (code, lines)
        walls[n, jobs] = wall, cpu
        print(f"| {n:,} | {jobs} | {wall:.1f} | {cpu:.1f} | {n / wall:.0f} | {rss} |")
    for jobs in sorted({j for _, j in runs}):
        if (100_000, jobs) in walls and (10_000, jobs) in walls:
            (w1, c1), (w2, c2) = walls[10_000, jobs], walls[100_000, jobs]
            print(f"\n--jobs {jobs}, 10k -> 100k patches: wall x{w2 / w1:.1f}, CPU x{c2 / c1:.1f}")


def long_run(path, seconds):
    wall, cpu, rss, lines, code, start = measure([*CLI, path, "--jobs", "2"], seconds)
    print(
        f"\n1,000,000 patches, --jobs 2: first record after {start:.0f} s (the checking"
        f" pass), {lines:,} patches in the next {seconds} s ({lines / seconds:.0f}/s), then"
        f" Ctrl-C (exit {code}); peak RSS {rss} MB"
    )


CLI = [sys.executable, "-m", "tactile.cli.main", "ep2", "analyze", "--json"]
SECTIONS = ("reader", "cli", "long", "grouping")


def main():
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1k and 10k patches only")
    ap.add_argument("--cli-max", type=int, default=100_000, help="largest file given to the CLI")
    ap.add_argument("--long", type=int, default=LONG_S, help="s of analysis of the 1M file")
    ap.add_argument("--only", default=",".join(SECTIONS), help="sections, of " + ",".join(SECTIONS))
    ap.add_argument(
        "--jobs",
        help="--jobs counts for every CLI size, e.g. 1 or 1,2 (default:"
        " 1 and 2 up to 10k patches, 2 beyond)",
    )
    args = ap.parse_args()
    only = set(args.only.split(","))
    signal.signal(signal.SIGINT, signal.default_int_handler)  # children may be Ctrl-C'd
    sizes = (1_000, 10_000) if args.quick else (1_000, 10_000, 100_000, 1_000_000)
    runs = [(1_000, 1), (1_000, 2), (10_000, 1), (10_000, 2), (100_000, 2)]
    if args.jobs:
        runs = [(n, int(j)) for n in (1_000, 10_000, 100_000) for j in args.jobs.split(",")]
    runs = [(n, j) for n, j in runs if n in sizes and n <= args.cli_max] if "cli" in only else []
    needed = {n for n, _ in runs}
    needed |= set(sizes[1:]) if "reader" in only else set()
    needed |= {1_000_000} if "long" in only and 1_000_000 in sizes and args.long > 0 else set()
    with tempfile.TemporaryDirectory() as tmp:
        files = {}
        for n in sorted(needed):
            files[n] = os.path.join(tmp, f"p{n}.csv")
            t0 = time.perf_counter()
            write_csv(files[n], n)
            size = os.path.getsize(files[n]) / 2**20
            print(f"wrote {n:,} patches: {size:,.0f} MiB in {time.perf_counter() - t0:.0f} s")
        print(f"\nload average before: {os.getloadavg()[0]:.1f} (2 cores)")
        if "reader" in only:
            reader({n: files[n] for n in sizes[1:]})
        if runs:
            analyze(files, runs)
        if 1_000_000 in files and "long" in only:
            long_run(files[1_000_000], args.long)
        print(f"\nload average after: {os.getloadavg()[0]:.1f}")
    if "grouping" in only:
        grouping((1_000, 10_000) if args.quick else (1_000, 10_000, 100_000))


if __name__ == "__main__":
    main()
