"""Many patches in order, one result at a time: the engine behind ``tactile ep2 analyze``.

``outcomes(named, req, split, jobs)`` (``req`` a ``patch_input.Request``) takes an
iterable of (``Contacts``, name) pairs (read lazily: ``contacts_csv.ContactsFile`` yields
patches as the file is read) and yields one ``Outcome`` per patch, in input order, as soon
as its chunk (and every chunk before it) is done.

Patches go in chunks of ``CHUNK`` consecutive patches (fewer where their contacts pass
``CHUNK_ROWS``), each chunk fitted by one ``analyze_patches`` call, which sorts it into
stacks of like size.  The chunks are the same whatever ``jobs`` is, so the output is too:
with ``jobs > 1`` chunks go to that many worker processes, at most a few chunks per
worker in flight, so memory does not grow with the file.  With ``split``, a patch whose
normals break (§6.2.5) is cut and analysed part by part (``analyze_sweep``); the others of
its chunk are still fitted together.

The unit of every number of a record (``in_unit``): ``analyze_patch`` works in the input's
length unit; ``in_unit(record, unit, scale)`` gives the record with lengths multiplied by
``scale`` (the file's unit -> ``unit``, ``tactile.units.display``), curvatures divided by
it, C and C_mean shifted by -(2/pi) ln(scale) (C = (2/pi) ln R, thesis §4.8.2), and a
``units`` field naming the unit of each number.
"""

import functools
from collections import deque
from dataclasses import dataclass

import numpy as np

from tactile.ep2 import geometry, patch_input
from tactile.ep2.api import analyze_sweep, sweep_parts
from tactile.ep2.batch import analyze_patches
from tactile.errors import DataError, InputError
from tactile.units import c_shift

MAX_JOBS = 256
CHUNK = 2048  # consecutive patches to a unit of work, fitted in stacks of like size
CHUNK_ROWS = 2**16  # ... and at most this many contacts, however large the patches
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


def analyze_one(group, name, req, split):
    """``Outcome`` of one ``Contacts`` group labelled ``name``, by ``analyze_sweep``."""
    try:
        results = analyze_sweep(
            group.points,
            group.normals,
            finger=group.finger,
            split=split,
            lines=group.lines,
            **req.keywords(),
        )
    except (DataError, InputError) as exc:
        return _outcome(name, len(group.points), exc)
    return _outcome(name, len(group.points), results)


def _outcome(name, n, results):
    """``Outcome`` from a list of results (split parts) or the exception that refused it."""
    if isinstance(results, InputError):  # e.g. a split part ``spread_problem`` refuses
        return Outcome(name, n, [], input_error=str(results))
    if isinstance(results, DataError):
        return Outcome(name, n, [], data_error=str(results))
    if len(results) == 1:
        return Outcome(name, n, [results[0].to_dict(name)])
    return Outcome(name, n, [r.to_dict(f"{name}#{i + 1}") for i, r in enumerate(results)])


def analyze_chunk(work, req, split):
    """[``Outcome``] of ``work``, a list of (``Contacts``, name): one ``analyze_patches``
    call for every patch of the chunk and every part of the ones ``split`` cuts (§6.2.5;
    ``api.sweep_parts``).  A cut patch is refused, as ``analyze_sweep`` refuses it, by its
    first part that is."""
    out = [None] * len(work)
    cut = _breaks([g for g, _ in work], req.jet.break_angle) if split else [False] * len(work)
    patches, owners = [], []  # owners[k]: the work index patches[k] belongs to
    for i, (g, name) in enumerate(work):
        parts = _parts(g, req.jet.break_angle) if cut[i] else None
        if isinstance(parts, Exception):
            out[i] = _outcome(name, len(g.points), parts)
            continue
        whole = {"points": g.points, "normals": g.normals, "finger": g.finger, "lines": g.lines}
        for part in parts or [whole]:
            patches.append(part)
            owners.append(i)
    results = analyze_patches(patches, **req.keywords())  # stacks of like size (``stacks``)
    found = {}
    for i, res in zip(owners, results, strict=True):
        found.setdefault(i, []).append(res)
    for i, res in found.items():
        g, name = work[i]
        refused = next((r for r in res if isinstance(r, Exception)), None)
        out[i] = _outcome(name, len(g.points), refused if refused is not None else res)
    return out


def _parts(group, angle):
    """``api.sweep_parts`` of a group ``_breaks`` found cut, or the exception it raised."""
    try:
        g = group
        return sweep_parts(g.points, g.normals, g.finger, g.lines, True, angle)
    except (DataError, InputError) as exc:
        return exc


def _breaks(groups, angle):
    """[bool] per ``Contacts`` group: whether ``analyze_sweep`` would cut it (its normals
    break, §6.2.5, or a zero normal makes it refuse, as ``analyze_one`` then says), for the
    groups of one size at once: ``geometry.unit_normals`` and
    ``patch_input.find_breaks`` on their stack."""
    out = [False] * len(groups)
    sizes = {}
    for i, g in enumerate(groups):
        if g.finger is not None:
            nrm = np.asarray(g.normals, float)
            if nrm.ndim != 2 or nrm.shape[1] != 3:
                out[i] = _breaks_one(g, angle)
            else:
                sizes.setdefault(len(nrm), []).append((i, nrm))
    for same in sizes.values():
        N, ok = geometry.unit_rows(np.stack([nrm for _, nrm in same]))
        ok = np.all(ok, axis=-1)  # else ``unit_normals`` refuses: a zero normal
        N = N[ok]
        live = [i for (i, _), keep in zip(same, ok.tolist(), strict=True) if keep]
        found = patch_input.find_breaks(N, [groups[i].finger for i in live], angle)
        for i, _ in same:
            out[i] = True
        for i, brk in zip(live, found, strict=True):
            out[i] = bool(brk)
    return out


def _breaks_one(group, angle):
    """``_breaks`` of one group (normals of another shape than (n, 3))."""
    try:
        nrm = geometry.unit_normals(np.asarray(group.normals, float))
        return bool(patch_input.find_breaks(nrm[None], [group.finger], angle)[0])
    except (DataError, InputError):
        return True  # ``analyze_one`` gives the refusal as ``analyze_sweep`` does


def _quiet_worker():
    """Workers leave Ctrl-C to the parent, which stops them (no traceback per worker)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def chunks(named):
    """Lists of (group, name) of consecutive patches: ``CHUNK`` each, or fewer where their
    contacts would pass ``CHUNK_ROWS`` (at least one patch a list)."""
    work, rows = [], 0
    for item in named:
        n = len(item[0].points)
        if work and (len(work) == CHUNK or rows + n > CHUNK_ROWS):
            yield work
            work, rows = [], 0
        work.append(item)
        rows += n
    if work:
        yield work


def outcomes(named, req, split=False, jobs=1):
    """Yield the ``Outcome`` of each (``Contacts``, name) pair of ``named`` in input order."""
    if jobs <= 1:
        for work in chunks(named):
            yield from analyze_chunk(work, req, split)
        return
    yield from _parallel(chunks(named), req, split, jobs)


def _parallel(work, req, split, jobs):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # fork where the platform has it: workers start at once and inherit the imports
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else None)
    with ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_quiet_worker) as pool:
        pending = deque()

        def submit():
            chunk = next(work, None)
            if chunk is not None:
                pending.append(pool.submit(analyze_chunk, chunk, req, split))

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


# the power of length of each numeric field (1: a length, -1: a curvature); "C" is the
# curvedness, a log; None: no unit (S, confidence, counts), or one fixed unit (rad, deg)
DIMENSIONS = {
    "radius": 1,
    "radius_interval": 1,
    "noise_pos": 1,
    "k1": -1,
    "k2": -1,
    "k1_interval": -1,
    "k2_interval": -1,
    "k1_mean": -1,
    "k2_mean": -1,
    "k1_std": -1,
    "k2_std": -1,
    "R_mean": -1,
    "R_std": -1,
    "C": "C",
    "C_mean": "C",
}
FIXED = {"noise_normal": "rad", "direction1": "1 (unit vector)"}
DIMENSIONLESS = ("S", "S_interval", "S_mean", "S_std", "confidence")


def units_of(unit):
    """{field: its unit} for lengths in ``unit``."""
    return dict(_units_of(unit))


@functools.lru_cache(maxsize=16)
def _units_of(unit):
    out = {}
    for name, power in DIMENSIONS.items():
        if power == "C":
            out[name] = f"1 ((2/pi) ln R, R in 1/{unit})"
        else:
            out[name] = unit if power == 1 else f"1/{unit}"
    out.update(FIXED)
    out.update({name: "1" for name in DIMENSIONLESS})
    out["discontinuities.angle_deg"] = "deg"
    return out


def in_unit(record, unit, scale=1.0):
    """``record`` (a ``PatchResult.to_dict``) in ``unit``, ``scale`` lengths per file length,
    with its ``units``.  A refusal (no ``shape``) has no number with a unit: as it is."""
    if record.get("shape") is None:
        return record
    out = dict(record)
    if scale != 1.0:
        for name, power in DIMENSIONS.items():
            if out.get(name) is not None:
                out[name] = _scaled(out[name], power, scale)
    out["units"] = units_of(unit)
    return out


def _scaled(value, power, scale):
    if isinstance(value, list | tuple):
        return [_scaled(v, power, scale) for v in value]
    if power == "C":
        return value + c_shift(scale)
    return value * scale if power == 1 else value / scale
