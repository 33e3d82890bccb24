"""The benches' one timer: the best of a few runs (the machine is shared; the least
disturbed run is the closest to the cost)."""

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
