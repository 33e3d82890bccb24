"""The batched-against-alone equality checks of EP1 and EP2 under other BLAS kernel paths:
OpenBLAS's core type (unset, Haswell, Sandybridge, Prescott) and its threads (1, 2), each in
its own pytest process.  Each check's tolerance is derived from the quantity's sensitivity
to its data (``tests/tolerance.py``); every check appends its worst ratio of |difference|
to tolerance to a log, and this script reports the worst per setting.  It must stay below 1
everywhere, a margin the tolerance has not been tuned to: the same tests fail at 1.

Run: ``.venv/bin/python bench/blas_paths.py [--cores Haswell,Sandybridge] [--threads 1,2]``.
Exit 1 if a ratio reaches 1 or a pytest run fails.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHECKS = (
    "tests/test_ep2_properties.py::test_fitting_a_stack_equals_fitting_each_patch_alone",
    "tests/test_ep2_properties.py::test_fitting_noise_free_patches_in_a_stack",
    "tests/test_ep2_batch.py::test_batch_equals_one_at_a_time",
    "tests/test_ep2_batch.py::test_stacked_preparation_equals_one_patch_at_a_time",
    "tests/test_ep2_default.py::test_per_patch_noise_in_a_batch_equals_the_keywords",
    "tests/test_ep2_stream.py::test_batched_records_are_the_per_patch_records_in_file_order",
    "tests/test_ep2_stream.py::test_chunks_jobs_and_block_sizes_give_the_same_bytes",
    "tests/test_ep2_families.py::test_jet2_equals_a_weighted_lstsq_and_is_exact_on_a_quadric",
    "tests/test_ep1_batch.py::test_single_equals_batch_on_random_and_degenerate_points",
    "tests/test_ep1_estimator.py::test_batch_equals_single_calls",
    "tests/test_ep1_estimator.py::test_scalar_path_agrees_with_batch_path",
)
CORES = ("", "Haswell", "Sandybridge", "Prescott")  # "": OpenBLAS picks the machine's own
THREADS = (1, 2)
_CORENAME = """
import ctypes, glob, os, numpy
here = os.path.dirname(numpy.__file__)
libs = glob.glob(os.path.join(here, os.pardir, 'numpy.libs', '*openblas*'))
name = '?'
for path in libs:
    lib = ctypes.CDLL(path)
    for sym in ('scipy_openblas_get_corename64_', 'openblas_get_corename'):
        if hasattr(lib, sym):
            f = getattr(lib, sym)
            f.restype = ctypes.c_char_p
            name = f().decode()
print(name)
"""


def environment(core, threads):
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENBLAS_")}
    env.update(OPENBLAS_NUM_THREADS=str(threads), PYTHONHASHSEED="0")
    if core:
        env["OPENBLAS_CORETYPE"] = core
    return env


def corename(env):
    """The kernel set OpenBLAS chose under ``env`` (numpy's bundled library), or '?'."""
    proc = subprocess.run(
        [sys.executable, "-c", _CORENAME], env=env, capture_output=True, text=True
    )
    return proc.stdout.strip() or "?"


def run(core, threads, checks):
    """(kernels, pytest exit code, [log rows]) of the checks under one setting."""
    env = environment(core, threads)
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "ratios.jsonl"
        env["TOLERANCE_LOG"] = str(log)
        proc = subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-p", "no:cacheprovider",
             *checks],
            cwd=ROOT, env=env, capture_output=True, text=True,
        )  # fmt: skip
        rows = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    return corename(env), proc.returncode, rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cores", default=",".join(CORES), help="OPENBLAS_CORETYPE values ('' unset)")
    ap.add_argument("--threads", default=",".join(map(str, THREADS)), help="OPENBLAS_NUM_THREADS")
    args = ap.parse_args(argv)
    cores = args.cores.split(",")
    threads = [int(t) for t in args.threads.split(",")]
    print("| OPENBLAS_CORETYPE | kernels | threads | checks | worst ratio | where | pytest |")
    print("|---|---|---|---|---|---|---|")
    bad = False
    for core in cores:
        for n in threads:
            kernels, code, rows = run(core, n, CHECKS)
            worst = max(rows, key=lambda r: r["ratio"], default={"ratio": float("nan")})
            where = f"{worst.get('test', '-').split('::')[-1]} {worst.get('check', '')}".strip()
            print(
                f"| {core or '(unset)'} | {kernels} | {n} | {len(rows)} | {worst['ratio']:.3f} "
                f"| {where} | {'ok' if code == 0 else f'exit {code}'} |",
                flush=True,
            )
            bad |= code != 0 or not rows or not worst["ratio"] < 1.0
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
