"""EP2 CLI per-patch overhead (issue 13): CPU seconds of ``tactile ep2 analyze`` on this tree
against a git revision's host library, side by side in one run, and whether their outputs
are byte for byte the same.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_cli_overhead.py [--against main]
[--patches 5000,10000] [--repeats 2] [--stages N]   (from a checkout:
PYTHONPATH=protocol:firmware:host:sim:studies first).

Files of 36-contact patches with a ``finger`` column, rows scattered through the file
(``ep2_cli_scale.write_csv``), and a copy with every 25th patch folded 40 deg along each
finger (``creased``: the discontinuity check finds breaks, ``--split`` cuts them).  Each
configuration (``--jobs 1``) runs alternately on this tree and on REV (``git archive`` of
its ``host``, as ``ep2_speed.py --against`` does): the best CPU seconds of ``--repeats``
runs each, their ratio, and whether the two trees wrote the same bytes.  The estimator's
fit is the same code in both unless REV differs there too; ``--split`` spends most of its
time fitting the cut parts one at a time (``analyze_patch``).

``--stages N`` instead times, in process, where the CPU of ``ep2 analyze --json`` on N
patches goes in each tree (``STAGES``: the reader's checking pass, the preparation, the
fit, the analysis after it, the results and their JSON, the rest), best of ``--repeats``.
"""

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
from ep2_cli_scale import ENV, cpu_s, write_csv
from ep2_speed import _export

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = [os.path.join(HERE, "..", d) for d in ("protocol", "firmware", "sim", "studies")]
# (name, flags, the folded file?, only at the smallest size?)
CONFIGS = (
    ("--json", ["--json"], False, False),
    ("table, folds", [], True, True),
    ("--json --split, folds", ["--json", "--split"], True, True),
)


def creased(src, dst, every=25, turn_deg=40.0):
    """``src`` with every ``every``-th patch folded: from each finger's fifth row on, its
    contacts (positions and normals) turned ``turn_deg`` about an x axis through their
    centroid, so each side is a surface by itself and the discontinuity check finds breaks."""
    with open(src) as fh:
        head, *rows = fh.read().splitlines()
    cells = [line.split(",") for line in rows]
    seen, moved = {}, {}
    for i, v in enumerate(cells):
        patch = int(v[7])
        k = seen[patch, v[6]] = seen.get((patch, v[6]), 0) + 1
        if patch % every == 0 and k > 4:
            moved.setdefault(patch, []).append(i)
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    for idx in moved.values():
        xyz = np.array([[float(x) for x in cells[i][:6]] for i in idx])
        mid = xyz[:, :3].mean(axis=0)
        xyz[:, :3] = (xyz[:, :3] - mid) @ rot.T + mid
        xyz[:, 3:] = xyz[:, 3:] @ rot.T
        for i, new in zip(idx, xyz, strict=True):
            cells[i][:6] = [f"{x:.8g}" for x in new]
    with open(dst, "w") as fh:
        fh.write("\n".join([head, *(",".join(v) for v in cells)]) + "\n")


def run(host, path, flags):
    """(CPU s, stdout bytes, exit code) of ``tactile ep2 analyze path flags --jobs 1``."""
    env = dict(ENV, PYTHONPATH=os.pathsep.join([host, *SOURCES]))
    cmd = [sys.executable, "-m", "tactile", "ep2", "analyze", path, *flags, "--jobs", "1"]
    cpu0 = cpu_s()
    proc = subprocess.run(cmd, env=env, capture_output=True, check=False)
    return cpu_s() - cpu0, proc.stdout, proc.returncode


# the stages timed by ``--stages``: (module, function, stage); a tree without one skips it
STAGES = (
    ("tactile.cli.cmd_ep2", "_checked", "reader, checking pass"),
    ("tactile.ep2.batch", "_prepare_stacked", "preparation (breaks, duplicates)"),
    ("tactile.ep2.centre_jet", "fit", "the fit (centre_jet.fit)"),
    ("tactile.ep2.jet_outcomes", "inputs", "analysis after the fit"),
    ("tactile.ep2.jet_outcomes", "outcomes", "analysis after the fit"),
    ("tactile.ep2.patch_result", "from_fields", "results, records, JSON"),
    ("tactile.ep2.many", "_outcome", "results, records, JSON"),
    ("tactile.ep2.record_units", "in_unit", "results, records, JSON"),
    ("tactile.jsonout", "dumps", "results, records, JSON"),
)
_STAGED = """
import importlib, io, json, sys, time
from contextlib import redirect_stdout
spent = {}
def timed(f, stage):
    def g(*a, **k):
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            spent[stage] = spent.get(stage, 0.0) + time.process_time() - t
    return g
for mod, name, stage in json.loads(sys.argv[2]):
    m = importlib.import_module(mod)
    if hasattr(m, name):
        setattr(m, name, timed(getattr(m, name), stage))
from tactile.cli.main import main
t0 = time.process_time()
with redirect_stdout(io.StringIO()):
    try:
        main(["ep2", "analyze", sys.argv[1], "--json", "--jobs", "1"])
    except SystemExit:
        pass
spent["whole run (imports aside)"] = time.process_time() - t0
print(json.dumps(spent))
"""


def stages(hosts, path, repeats):
    """[{stage: best CPU s}] per host: one in-process ``ep2 analyze --json`` run each,
    alternating, with the functions of ``STAGES`` timed."""
    import json

    best = [{} for _ in hosts]
    for _ in range(repeats):
        for k, host in enumerate(hosts):
            env = dict(ENV, PYTHONPATH=os.pathsep.join([host, *SOURCES]))
            args = [sys.executable, "-c", _STAGED, path, json.dumps(STAGES)]
            out = json.loads(subprocess.run(args, env=env, capture_output=True, check=True).stdout)
            for stage, cpu in out.items():
                best[k][stage] = min(best[k].get(stage, np.inf), cpu)
    for b in best:
        named = sum(v for s, v in b.items() if not s.startswith("whole"))
        b["the rest (reader's second pass, printing, chunks)"] = (
            b.pop("whole run (imports aside)") - named
        )
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--against", default="main", help="git revision to compare (default main)")
    ap.add_argument("--patches", default="5000,10000", help="file sizes, comma separated")
    ap.add_argument("--repeats", type=int, default=2, help="best of, each configuration")
    ap.add_argument("--stages", type=int, metavar="N", help="only where the CPU goes, N patches")
    args = ap.parse_args()
    ours = os.path.join(HERE, "..", "host")
    if args.stages:
        with tempfile.TemporaryDirectory() as tmp:
            theirs, path = _export(args.against, tmp), os.path.join(tmp, "p.csv")
            write_csv(path, args.stages)
            old, new = stages((theirs, ours), path, args.repeats)
        print(f"| {args.stages:,} patches, --json | {args.against} CPU (s) | this tree CPU (s) |")
        print("|---|---|---|")
        for stage in dict.fromkeys([*old, *new]):
            print(f"| {stage} | {old.get(stage, 0):.2f} | {new.get(stage, 0):.2f} |")
        return
    print(f"| patches | output | {args.against} CPU (s) | this tree CPU (s) | ratio | same bytes |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        theirs = _export(args.against, tmp)
        sizes = [int(v) for v in args.patches.split(",")]
        for n in sizes:
            plain = os.path.join(tmp, f"p{n}.csv")
            write_csv(plain, n)
            folded = os.path.join(tmp, f"p{n}_folded.csv")
            if any(fold and (n == min(sizes) or not small) for _, _, fold, small in CONFIGS):
                creased(plain, folded)
            for name, flags, fold, small in CONFIGS:
                if small and n != min(sizes):
                    continue
                cpu, same = compare((theirs, ours), folded if fold else plain, flags, args.repeats)
                print(
                    f"| {n:,} | {name} | {cpu[0]:.2f} | {cpu[1]:.2f} | {cpu[0] / cpu[1]:.2f}"
                    f" | {'yes' if same else 'NO'} |",
                    flush=True,
                )


def compare(hosts, path, flags, repeats):
    """([best CPU s per host], whether they wrote the same stdout), runs alternating."""
    best, outs = [np.inf] * len(hosts), [None] * len(hosts)
    for _ in range(repeats):
        for k, host in enumerate(hosts):
            cpu, out, code = run(host, path, flags)
            assert code in (0, 3), (host, flags, code)
            assert outs[k] in (None, out)  # each tree writes the same every time
            best[k], outs[k] = min(best[k], cpu), out
    return best, all(o == outs[0] for o in outs)


if __name__ == "__main__":
    main()
