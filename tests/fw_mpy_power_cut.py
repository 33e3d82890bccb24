"""Power cuts at every flash call of the board's storage, on MicroPython (or CPython).

One line per cut (tests/power_cut.py): the rename kind, the call number, the call cut and
what a boot then loaded.  Then, where the rename refuses an existing file, a second write
cut at every call after each first cut: a line for each boot that found neither what the
board booted with before nor the newest copy, and their count.  test_fw_micropython.py
requires every boot to find the old or the new copy.
"""

import os

import power_cut

ROOT = "power_cut_flash"
try:
    os.mkdir(ROOT)
except OSError:
    pass
for refuse in (False, True):
    kind = "refuses" if refuse else "replaces"
    rows = power_cut.sweep(ROOT, refuse)
    for k, call, seen_settings, seen_cal in rows:
        print(kind, k, call, seen_settings, seen_cal)
    if not refuse:
        continue  # (a replacing rename never leaves the file missing for a second write)
    bad = 0
    for k1 in range(len(rows)):
        for k2 in range(len(rows)):
            first, second = power_cut.cut_twice(ROOT, k1, k2, refuse)
            for was, now in zip(first, second):
                if now not in (was, "newer"):
                    print(kind, "second cut", k1, k2, first, second)
                    bad += 1
    print(kind, "second cuts", len(rows) * len(rows), "bad", bad)
