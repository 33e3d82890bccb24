"""Reliability probes: the board loses power while it writes its flash.

The board's storage (``tactile_fw.storage.DirStorage``) on a real directory, with the power
cut at every filesystem call of storing new settings and a new calibration (the harness of
``tests/power_cut.py``: open, write with half its bytes landed, close, stat, rename,
remove), then the loaders a boot runs.  A probe holds when every boot finds the old copy or
the new one, never the defaults, and the uncut write ends with the new one.  The emulated
Pico's own run (a boot after every erase and program of its littlefs) is
``tests/test_pico_power_cut.py``: a boot per operation is too slow for this table.
"""

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import power_cut  # noqa: E402  (the harness the firmware's tests use)

AREA = "Power cuts on the board's flash"
RENAMES = (("littlefs and POSIX: rename replaces", False), ("FAT: rename refuses", True))


def _sweep(refuse):
    """(why not, '' if held; the number of calls cut): every cut of one write must boot the
    old or the new copy, and the uncut write the new one."""
    with tempfile.TemporaryDirectory() as root:
        rows = power_cut.sweep(root, refuse)
    n = len(rows) - 1
    for k, call, seen_settings, seen_cal in rows:
        if {seen_settings, seen_cal} - {"old", "new"}:
            return f"cut at call {k} ({call}): settings {seen_settings}, calibration {seen_cal}", n
    if rows[-1][1:] != (None, "new", "new"):
        return f"the uncut write boots {rows[-1][2:]}", n
    return "", n


def _second_cuts(refuse, n):
    with tempfile.TemporaryDirectory() as root:
        for k1 in range(n + 1):
            for k2 in range(n + 1):
                first, second = power_cut.cut_twice(root, k1, k2, refuse)
                if any(now not in (was, "newer") for was, now in zip(first, second)):
                    return f"cuts at calls {k1}, {k2}: booted {first}, then {second}"
    return ""


def probes():
    for kind, refuse in RENAMES:
        why, n = _sweep(refuse)
        yield (
            f"`config --persist` and `calibrate` ({kind}): power cut at each of the {n} "
            "filesystem calls of writing settings.bin and cal0.bin, then a boot",
            "boots with the old or the new settings and calibration, never the defaults or "
            "identity (was: defaults at 2 of 10 calls)",
            "held" if not why else f"FAILED: {why}",
        )
        why = _second_cuts(refuse, n)
        yield (
            f"the same ({kind}), and a third write cut at each call after each first cut",
            "boots with what the board booted with after the first cut, or the third",
            "held" if not why else f"FAILED: {why}",
        )
