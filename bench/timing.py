"""The benches' one timer: the best of a few runs (the machine is shared; the least
disturbed run is the closest to the cost); and the peak memory of a process tree."""

import os
import time


def best_of(fn, repeats=3, clock=time.perf_counter, warm=False):
    """(fewest seconds of ``repeats`` calls of ``fn()`` on ``clock``, the last call's value);
    with ``warm`` one untimed call first (imports, caches, allocator)."""
    if warm:
        fn()
    best, value = float("inf"), None
    for _ in range(repeats):
        t0 = clock()
        value = fn()
        best = min(best, clock() - t0)
    return best, value


def peak_rss_mb(pid):
    """Largest VmHWM (MB) of ``pid`` and its live descendants, 0 when gone."""
    peak, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/status") as fh:
                hwm = [ln for ln in fh if ln.startswith("VmHWM:")]
            peak = max(peak, int(hwm[0].split()[1]) // 1024 if hwm else 0)
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as fh:
                    todo += [int(c) for c in fh.read().split()]
        except (FileNotFoundError, ProcessLookupError, IndexError):
            continue
    return peak
