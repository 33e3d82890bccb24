"""Many patches in order, one result at a time: the engine behind ``tactile ep2 analyze``.

``outcomes(groups, opts, split, jobs)`` yields one ``Outcome`` per patch, in the order of
``groups``, as soon as that patch (and every patch before it) is done, so a caller can
print while the rest is computed.  With ``jobs > 1`` chunks of patches go to that many
worker processes; at most a few chunks per worker are in flight, so memory does not grow
with the file, and the outcomes are the same objects in the same order as with one job.

Each patch is still analysed by ``analyze_sweep`` one at a time (the batched estimator of
issue 13 is not written yet): processes divide the wall time, they do not remove the
per-patch cost.
"""

from collections import deque
from dataclasses import dataclass

from tactile.errors import DataError, InputError

MAX_JOBS = 256
_IN_FLIGHT = 4  # chunks queued per worker: enough to keep it busy, little memory


@dataclass
class Outcome:
    """One patch: ``records`` (one dict per result, split parts included), or ``data_error``
    (the data do not determine it: exit 3, the others go on), or ``input_error`` (a part EP2
    cannot represent: exit 2, nothing after it runs)."""

    name: object
    n_points: int
    records: list
    data_error: str | None = None
    input_error: str | None = None


def analyze_one(group, name, opts, split):
    """``Outcome`` of one ``Contacts`` group labelled ``name``."""
    from tactile.ep2.api import analyze_sweep

    n = len(group.points)
    try:
        results = analyze_sweep(
            group.points, group.normals, finger=group.finger, split=split, lines=group.lines, **opts
        )
    except InputError as exc:  # a split part EP2 cannot represent (``ep2.extent``)
        return Outcome(name, n, [], input_error=str(exc))
    except DataError as exc:
        return Outcome(name, n, [], data_error=str(exc))
    if len(results) == 1:
        return Outcome(name, n, [results[0].to_dict(name)])
    return Outcome(name, n, [r.to_dict(f"{name}#{i + 1}") for i, r in enumerate(results)])


def _chunk(work, opts, split):
    return [analyze_one(g, name, opts, split) for g, name in work]


def _quiet_worker():
    """Workers leave Ctrl-C to the parent, which stops them (no traceback per worker)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def chunk_size(n_patches, jobs):
    """Patches per chunk: small enough that every worker gets several chunks (even load,
    early first output), large enough that pickling a chunk costs little beside its fits."""
    return max(1, min(64, n_patches // (jobs * 8)))


def outcomes(groups, names, opts, split=False, jobs=1):
    """Yield the ``Outcome`` of each group (labelled by ``names``) in input order."""
    if jobs <= 1 or len(groups) < 2:
        for g, name in zip(groups, names):
            yield analyze_one(g, name, opts, split)
        return
    yield from _parallel(groups, names, opts, split, jobs)


def _parallel(groups, names, opts, split, jobs):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    size = chunk_size(len(groups), jobs)
    starts = iter(range(0, len(groups), size))
    # fork where the platform has it: workers start at once and inherit the imports
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else None)
    with ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_quiet_worker) as pool:
        pending = deque()

        def submit():
            start = next(starts, None)
            if start is not None:
                work = list(zip(groups[start : start + size], names[start : start + size]))
                pending.append(pool.submit(_chunk, work, opts, split))

        for _ in range(jobs * _IN_FLIGHT):
            submit()
        try:
            while pending:
                done = pending.popleft().result()
                submit()
                yield from done
        finally:
            for f in pending:
                f.cancel()
