"""EP2 at scale: `tactile ep2 analyze --json` wall and peak RSS at 10k, 100k and 1M patches,
and CPU per patch of the default estimator beside two batched 2-jets, on one mixed set.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_scale.py [--sizes 10000,100000,1000000]
[--jobs 1] [--cpu-patches 768] [--only cpu,stages,cli]   (from a checkout:
PYTHONPATH=protocol:firmware:host:sim:studies first).

The mixed set: three-finger sweeps (3 fingers x 3..6 stops x 1..2 readings: 9..36 contacts)
and square grids (3x3..6x6) over a 4-wide patch of spheres, cylinders, saddles and pits of
radius 8, noise 0.01 in position and normal, cycled.  The CSVs are written into a temporary
directory (about 200 MB at 1M patches) with numpy and removed afterwards.

- ``cpu``: CPU seconds (``time.process_time``) per patch, best of 3, in this process:
  ``tactile.ep2.analyze_patches`` (the default), the families bench's batched 2-jet
  (``tactile_studies.ep2.jet2.analyze``) and a lean batched numpy 2-jet (``lean_jet2``:
  one stacked least-squares solve per patch size, no per-patch Python), side by side, in a
  process whose allocator keeps its freed heap (``batch.keep_heap``), as the CLI's is.
- ``stages``: where the default's CPU goes, on the same set: its stages' CPU per patch
  (each stage's functions timed in place, in the best of 3 runs) against the lean 2-jet.
- ``cli``: each size through ``python -m tactile.cli.main ep2 analyze --json`` in a child
  process: wall, CPU (``RUSAGE_CHILDREN``) and peak RSS (the largest VmHWM of it and its
  workers, sampled from /proc every 0.1 s; not ``ru_maxrss`` of the children, which counts
  this process's pages at the fork before the exec).
"""

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from bench_args import positive_int  # noqa: E402
from timing import peak_rss_mb  # noqa: E402

from tactile.ep2 import analyze_patches, batch, jet_answers, local_jet, patch_input  # noqa: E402
from tactile.ep2.api import PatchResult  # noqa: E402
from tactile.ep2.batch import keep_heap  # noqa: E402
from tactile_sim.ep2 import make  # noqa: E402
from tactile_studies.ep2 import jet2  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = [os.path.join(HERE, "..", d) for d in ("protocol", "firmware", "host", "sim", "studies")]
ENV = {
    **os.environ,
    "PYTHONPATH": os.pathsep.join(filter(None, [*SOURCES, os.environ.get("PYTHONPATH")])),
    "OPENBLAS_NUM_THREADS": "1",
}
CLI = [sys.executable, "-m", "tactile.cli.main", "ep2", "analyze", "--json", "--quiet"]
KINDS = ("sphere", "cylinder", "saddle", "pit")
NOISE = 0.01


def layouts():
    """[(xy (n, 2), finger (n,))]: the sweeps and grids of the mixed set, 9..36 contacts."""
    out = []
    for stops in (3, 4, 5, 6):
        for repeats in (1, 2):
            x = np.repeat([0.0, 2.0, 4.0], stops * repeats)
            y = np.tile(np.repeat(np.linspace(0.0, 4.0, stops), repeats), 3)
            out.append((np.column_stack([x, y]), np.repeat(np.arange(3), stops * repeats)))
    for side in (3, 4, 5, 6):
        g = np.linspace(0.0, 4.0, side)
        out.append(
            (
                np.column_stack([np.repeat(g, side), np.tile(g, side)]),
                np.repeat(np.arange(side), side),
            )
        )
    return out


def bases():
    """[dict(points, normals, finger)]: every layout on every kind, noise-free."""
    out = []
    for kind in KINDS:
        obj = make(kind, 8.0)
        for xy, finger in layouts():
            z, _, _ = obj.eval(xy[:, 0], xy[:, 1])
            out.append(
                {
                    "points": np.column_stack([xy, z]),
                    "normals": obj.normals(xy[:, 0], xy[:, 1]),
                    "finger": finger,
                }
            )
    return out


def mixed(n, seed=0):
    """``n`` patch dicts cycling through ``bases()``, each with its own noise draw."""
    rng = np.random.default_rng(seed)
    base = bases()
    out = []
    for i in range(n):
        b = base[i % len(base)]
        p = b["points"] + NOISE * rng.standard_normal(b["points"].shape)
        nrm = b["normals"] + NOISE * rng.standard_normal(b["normals"].shape)
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        out.append({"points": p, "normals": nrm, "finger": b["finger"]})
    return out


def write_csv(path, n, block=20_000):
    """The mixed set of ``n`` patches as a contacts CSV (patch ids 0..n-1), a block at a time."""
    with open(path, "w") as fh:
        fh.write("# units: mm\nx,y,z,nx,ny,nz,finger,patch\n")
        for start in range(0, n, block):
            ps = mixed(min(block, n - start), seed=start)
            rows = np.concatenate([np.column_stack([p["points"], p["normals"]]) for p in ps])
            finger = np.concatenate([p["finger"] for p in ps])
            patch = np.concatenate([np.full(len(p["finger"]), start + i) for i, p in enumerate(ps)])
            cols = [np.char.mod("%.8g", rows[:, j]) for j in range(6)]
            cols += [finger.astype(str), patch.astype(str)]
            text = cols[0]
            for c in cols[1:]:
                text = np.char.add(np.char.add(text, ","), c)
            fh.write("\n".join(text.tolist()) + "\n")


def lean_jet2(patches):
    """The lean batched 2-jet: per patch size one stacked solve of z = c + g.x + x^T A x / 2
    from positions and slopes (unit weights), in the frame of the mean normal; S at 0.
    [S] per patch."""
    out = [None] * len(patches)
    groups = {}
    for j, d in enumerate(patches):
        groups.setdefault(len(d["points"]), []).append(j)
    for idx in groups.values():
        P = np.stack([patches[j]["points"] for j in idx])
        N = np.stack([patches[j]["normals"] for j in idx])
        z = N.mean(axis=1)
        z /= np.linalg.norm(z, axis=1, keepdims=True)
        x = np.cross([0.0, 1.0, 0.0], z)
        x /= np.linalg.norm(x, axis=1, keepdims=True)
        y = np.cross(z, x)
        R = np.stack([x, y, z], axis=1)  # (B, 3, 3)
        Q = np.einsum("bij,bnj->bni", R, P - P.mean(axis=1, keepdims=True))
        M = np.einsum("bij,bnj->bni", R, N)
        u, v, h = Q[..., 0], Q[..., 1], Q[..., 2]
        one, zero = np.ones_like(u), np.zeros_like(u)
        rows_p = np.stack([one, u, v, u * u / 2, u * v, v * v / 2], -1)
        rows_x = np.stack([zero, one, zero, u, v, zero], -1)
        rows_y = np.stack([zero, zero, one, zero, u, v], -1)
        A = np.concatenate([rows_p, rows_x, rows_y], axis=1)
        b = np.concatenate([h, -M[..., 0] / M[..., 2], -M[..., 1] / M[..., 2]], axis=1)
        AtA = np.einsum("bni,bnj->bij", A, A)
        Atb = np.einsum("bni,bn->bi", A, b)
        c = np.linalg.solve(AtA, Atb[..., None])[..., 0]
        g, H = c[:, 1:3], c[:, 3:]
        E, F, G = 1 + g[:, 0] ** 2, g[:, 0] * g[:, 1], 1 + g[:, 1] ** 2
        w = np.sqrt(1 + g[:, 0] ** 2 + g[:, 1] ** 2)
        L, Mm, Nn = H[:, 0] / w, H[:, 1] / w, H[:, 2] / w
        K = (L * Nn - Mm * Mm) / (E * G - F * F)
        Hm = (E * Nn - 2 * F * Mm + G * L) / (2 * (E * G - F * F))
        d = np.sqrt(np.maximum(Hm * Hm - K, 0.0))
        S = 2 / np.pi * np.arctan2(2 * Hm, 2 * d)
        for b_, j in enumerate(idx):
            out[j] = float(S[b_])
    return out


LEAN_REPEATS = 20


def cpu_per_patch(n, repeats=3):
    """{name: µs of CPU a patch} on ``mixed(n)``, each best of ``repeats`` (the lean 2-jet,
    a few ms a run, of ``LEAN_REPEATS``: its best of 3 moved by up to 50 %)."""
    patches = mixed(n)
    for_jet2 = [{**p, "stated": False, "noise_pos": NOISE, "noise_normal": NOISE} for p in patches]
    runs = {
        "default (analyze_patches)": lambda: analyze_patches(patches),
        "families bench 2-jet (jet2.analyze)": lambda: jet2.analyze(for_jet2),
        "lean batched 2-jet": (lean := lambda: lean_jet2(patches)),
    }
    out = {}
    for name, fn in runs.items():
        fn()  # warm: imports, caches
        best = float("inf")
        for _ in range(LEAN_REPEATS if fn is lean else repeats):
            t0 = time.process_time()
            fn()
            best = min(best, time.process_time() - t0)
        out[name] = 1e6 * best / n
    return out


STAGES = (  # (name, module or class, attribute): the default's stages, in the order run
    ("input checked and centred", patch_input, "prepare_stack"),
    ("edge, tilt and turn screens", batch, "_screens"),
    ("fit: frames, rows, the noise and answer QR passes", local_jet, "_fit_once"),
    ("fit: the outlier test", local_jet, "worst_contact"),
    ("fit: the answer's jet and covariance", jet_answers, "answer"),
    ("fit: positions against normals (consistency)", local_jet, "refuse_disagreeing"),
    ("answers: S, k, 95 % intervals, labels", jet_answers, "outcomes"),
    ("jump screen", batch, "_smooth"),
    ("result objects", PatchResult, "of"),
)


def stage_cpu(n, repeats=3):
    """[(stage, µs of CPU a patch)] of ``analyze_patches`` on ``mixed(n)``, the rest last,
    from the best of ``repeats`` runs: each stage's function timed where it is looked up."""
    patches = mixed(n)
    spent = {name: 0.0 for name, _, _ in STAGES}

    def timed(name, fn):
        def run(*args, **kw):
            t0 = time.process_time()
            try:
                return fn(*args, **kw)
            finally:
                spent[name] += time.process_time() - t0

        return run

    originals = [(owner, attr, owner.__dict__[attr]) for _, owner, attr in STAGES]
    for name, owner, attr in STAGES:
        wrapped = timed(name, getattr(owner, attr))
        setattr(owner, attr, staticmethod(wrapped) if isinstance(owner, type) else wrapped)
    try:
        analyze_patches(patches)  # warm
        best = None
        for _ in range(repeats):
            spent.update({name: 0.0 for name, _, _ in STAGES})
            t0 = time.process_time()
            analyze_patches(patches)
            total = time.process_time() - t0
            if best is None or total < best[0]:
                best = (total, dict(spent))
    finally:
        for owner, attr, original in originals:
            setattr(owner, attr, original)
    total, spent = best
    rows = [(name, 1e6 * v / n) for name, v in spent.items()]
    return [*rows, ("the rest (stacking, padding, per-patch Python)", 1e6 * total / n - sum(
        v for _, v in rows))]  # fmt: skip


def run_cli(path, jobs):
    """(wall s, CPU s, peak RSS MB, output lines, exit code) of one ``ep2 analyze --json``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out:
        proc = subprocess.Popen(
            [*CLI, path, "--jobs", str(jobs)], stdout=out, stderr=subprocess.DEVNULL, env=ENV
        )
        peak = 0
        while proc.poll() is None:
            peak = max(peak, peak_rss_mb(proc.pid))
            time.sleep(0.1)
        wall = time.perf_counter() - t0
        out.seek(0)
        lines = sum(block.count(b"\n") for block in iter(lambda: out.read(1 << 20), b""))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return wall, cpu, peak, lines, proc.returncode


def _counts(text):
    """An ``argparse`` type: a comma-separated list of whole numbers of at least 1."""
    return [positive_int(v) for v in text.split(",")]


def main(argv=None):
    keep_heap()  # (as the CLI: the allocator keeps the stacks' pages)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=_counts, default="10000,100000,1000000")
    ap.add_argument("--jobs", type=_counts, default="1")
    ap.add_argument("--cpu-patches", type=positive_int, default=768)
    ap.add_argument("--only", default="cpu,cli")
    args = ap.parse_args(argv)
    only = set(args.only.split(","))
    if not only <= {"cpu", "stages", "cli"}:
        ap.error(f"--only: {args.only!r}: not a list of cpu, stages, cli")
    if "cpu" in only:
        n = args.cpu_patches
        us = cpu_per_patch(n)
        lean = us["lean batched 2-jet"]
        fam = us["families bench 2-jet (jet2.analyze)"]
        print(f"\nCPU per patch, {n} mixed sweeps and grids of 9-36 contacts (best of 3; the lean"
              f" 2-jet of {LEAN_REPEATS}):\n")  # fmt: skip
        print("| estimator | CPU per patch (µs) | x families 2-jet | x lean 2-jet |")
        print("|---|---|---|---|")
        for name, v in us.items():
            print(f"| {name} | {v:.0f} | {v / fam:.1f} | {v / lean:.1f} |")
    if "stages" in only:
        n = args.cpu_patches
        lean = cpu_per_patch(n)["lean batched 2-jet"]
        rows = stage_cpu(n)
        print(f"\nThe default's CPU per patch by stage, {n} mixed patches (best of 3):\n")
        print("| stage | CPU per patch (µs) | x lean 2-jet |")
        print("|---|---|---|")
        for name, v in rows:
            print(f"| {name} | {v:.0f} | {v / lean:.1f} |")
        total = sum(v for _, v in rows)
        print(f"| all | {total:.0f} | {total / lean:.1f} |")
    if "cli" in only:
        print("\n| patches | jobs | file (MB) | wall (s) | CPU (s) | peak RSS (MB) |")
        print("|---|---|---|---|---|---|")
        with tempfile.TemporaryDirectory() as tmp:
            for n in args.sizes:
                path = os.path.join(tmp, f"mixed_{n}.csv")
                write_csv(path, n)
                mb = os.path.getsize(path) / 1e6
                for jobs in args.jobs:
                    wall, cpu, rss, lines, code = run_cli(path, jobs)
                    assert code in (0, 3) and lines == n, (code, lines, n)
                    print(
                        f"| {n:,} | {jobs} | {mb:.0f} | {wall:.1f} | {cpu:.1f} | {rss} |",
                        flush=True,
                    )
                os.remove(path)


if __name__ == "__main__":
    main()
