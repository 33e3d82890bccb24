"""Hostile-world probes (issue 12): one table per area for docs/reliability.md.

Run: .venv/bin/python bench/reliability.py [--area NAME] > table.md

Each ``bench/reliability_<area>.py`` module holds ``AREA`` (a title) and ``probes()``,
which yields ``(probe, promise, outcome)``: what was tried, what the user is promised
(exit code, message, no data lost) and what happened, ``held`` or ``FAILED: why``.  The
probes run the real CLI in subprocesses or in-process against real files, ptys and the
emulator; ``tests/test_reliability.py`` requires every one to hold.  A module's ``COVERED``
maps a probe (its function) to the tests of ``tests/`` that make the same assertions on
the same fault; the test leaves those probes to them (``covered=False``), this script runs
every probe.
"""

import argparse
import importlib
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def areas():
    """Names of the probe modules, in file order."""
    return sorted(p.stem.removeprefix("reliability_") for p in HERE.glob("reliability_*.py"))


def module(name):
    """The probe module of one area."""
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    return importlib.import_module(f"reliability_{name}")


def run_area(name, covered=True):
    """(title, [(probe, promise, outcome)]) of one area; ``covered=False`` leaves out the
    probes its ``COVERED`` gives to a test of ``tests/``."""
    mod = module(name)
    skip = set(getattr(mod, "COVERED", {})) if not covered else set()
    return mod.AREA, list(mod.probes(skip=skip) if skip else mod.probes())


def table(title, rows):
    held = sum(1 for *_, out in rows if out == "held")
    lines = [f"### {title}: {held} of {len(rows)} held", "", "| probe | promise | outcome |"]
    lines.append("|---|---|---|")
    lines += [f"| {p} | {w} | {o} |" for p, w, o in rows]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--area", choices=areas(), help="only this area")
    args = ap.parse_args(argv)
    failed = 0
    for name in [args.area] if args.area else areas():
        title, rows = run_area(name)
        failed += sum(1 for *_, out in rows if out != "held")
        print(table(title, rows), end="\n\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
