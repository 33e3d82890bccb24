"""The test suite's wall and CPU time, as ``make test`` runs it (``pytest -n auto``) and,
with ``--serial``, in one process, side by side in one run.

Run: ``.venv/bin/python bench/suite_time.py [--serial] [-- PYTEST ARGS]``.

CPU is the children's user + system time (``resource.RUSAGE_CHILDREN``), so it counts the
xdist workers and every emulator, compiler and node process the tests start.  The 10
slowest tests of each run are printed by pytest itself (``--durations=10`` in pyproject).
"""

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(extra):
    """(wall s, CPU s, exit code, pytest's count line) of one pytest run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", *extra],
        cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONHASHSEED": "0"},
    )  # fmt: skip
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    said = [ln for ln in proc.stdout.splitlines() if " passed" in ln or " failed" in ln]
    return wall, cpu, proc.returncode, said[-1] if said else ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--serial", action="store_true", help="also run it in one process")
    ap.add_argument("pytest_args", nargs="*", help="after --: passed to pytest")
    args = ap.parse_args()
    rows = [("make test (-n auto)", ["-n", "auto", "--dist", "worksteal", *args.pytest_args])]
    if args.serial:
        rows.append(("one process", args.pytest_args))
    print(f"{os.cpu_count()} CPUs")
    print("| run | wall s | CPU s | exit | pytest says |")
    print("|---|---|---|---|---|")
    for name, extra in rows:
        wall, cpu, code, last = run(extra)
        print(f"| {name} | {wall:.0f} | {cpu:.0f} | {code} | {last.strip('= ')} |", flush=True)


if __name__ == "__main__":
    main()
