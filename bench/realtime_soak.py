"""The real-time tests, run again and again beside CPU hogs: do they hold on a busy machine?

Run: ``.venv/bin/python bench/realtime_soak.py [--runs 20] [--hogs 2] [-- PYTEST ARGS]``
(e.g. ``-- -k "not pico and not flash and not natmod and not readme"`` for the pty and
QEMU tests alone).

A real-time test (marked ``realtime``) runs an emulator or a board on the wall clock: a
pty server, QEMU, the emulated Pico, ``tactile emulate`` in another process.  Such a test
must assert what the board and host report (late flags, counted loss, the end of the run
reaching the host), never that the machine was fast enough.  This runs them ``--runs``
times in one process each, beside ``--hogs`` busy loops (one per CPU on this 2-core
machine), and prints each run's outcome with the first assertion lines of a failure, then
the count of runs that passed and which tests failed in which runs.
Exit 0 when every run passed.
"""

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FAILED = re.compile(r"^FAILED (\S+)", re.M)


def hogs(n):
    """``n`` processes that spin on a CPU until killed."""
    spin = "while True: pass"
    return [subprocess.Popen([sys.executable, "-c", spin]) for _ in range(n)]


def one_run(pytest_args):
    """(passed?, [failed test ids], its assertion lines, seconds) of one pytest run."""
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-p", "no:xdist",
         "-m", "realtime", "-o", "addopts=-q -ra", *pytest_args],
        cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONHASHSEED": "0"},
    )  # fmt: skip
    said = [ln for ln in proc.stdout.splitlines() if ln.startswith("E  ")][:6]
    return proc.returncode == 0, FAILED.findall(proc.stdout), said, time.monotonic() - start


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="pytest runs, one after another")
    ap.add_argument("--hogs", type=int, default=2, help="busy processes beside them")
    ap.add_argument("pytest_args", nargs="*", help="after --: passed to pytest")
    args = ap.parse_args(argv)
    spinning = hogs(args.hogs)
    failures, passed = {}, 0
    try:
        for k in range(args.runs):
            ok, failed, said, seconds = one_run(args.pytest_args)
            passed += ok
            for test in failed:
                failures.setdefault(test, []).append(k + 1)
            print(f"run {k + 1}: {'passed' if ok else 'FAILED ' + ' '.join(failed)} "
                  f"({seconds:.0f} s)", *said, sep="\n    ", flush=True)  # fmt: skip
    finally:
        for p in spinning:
            p.kill()
    print(f"\n{passed} of {args.runs} runs passed beside {args.hogs} CPU hogs")
    for test, runs in sorted(failures.items()):
        print(f"  {test}: failed in runs {', '.join(map(str, runs))}")
    return 0 if passed == args.runs else 1


if __name__ == "__main__":
    sys.exit(main())
