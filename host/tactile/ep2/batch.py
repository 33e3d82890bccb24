"""Many patches at once: ``analyze_patches`` (issue 13, first step).

Each patch is prepared as ``analyze_patch`` prepares it (validation, duplicates, centring),
then a chunk of patches is fitted by one ``centre_jet.fit`` call on a padded stack with a
row mask (the fit is batch-first: the stack equals each patch alone, tested), and the
analysis after the fit (positions-versus-normals test, determination, intervals, label, grid
statistics: ``api.jet_outcomes``) runs on the whole stack too; only the assembly of each
patch's result is per patch.  The result per patch equals ``analyze_patch``'s to
round-off; a patch that is refused or malformed gives its exception in its place and the
others still come out.

Only the default method is batched; ``method="spline"`` falls back to one patch at a time.
"""

import numpy as np

from tactile.ep2 import api, centre_jet
from tactile.errors import DataError, InputError

CHUNK = 256  # patches per fit call (bench/ep2_speed.py, ep2_tradeoff.py: best of 16-1024)


def analyze_patches(patches, *, chunk=CHUNK, **kw):
    """[PatchResult or DataError/InputError] for ``patches``, an iterable of (points,
    normals) pairs or dicts with ``points``, ``normals`` and optionally ``finger``,
    ``lines``.  Keyword options are ``analyze_patch``'s and apply to every patch."""
    out = []
    todo = []
    for p in patches:
        todo.append(p)
        if len(todo) == chunk:
            out += _chunk(todo, kw)
            todo = []
    return out + (_chunk(todo, kw) if todo else [])


def _unpack(p):
    if isinstance(p, dict):
        return p["points"], p["normals"], p.get("finger"), p.get("lines")
    points, normals = p
    return points, normals, None, None


def _chunk(patches, kw):
    kw = {**_defaults(), **kw}
    maps = kw.pop("maps", False)
    if kw["method"] == "spline":
        return [_one(p, dict(kw, maps=maps)) for p in patches]
    prepared, results = [], [None] * len(patches)
    for j, p in enumerate(patches):
        points, normals, finger, lines = _unpack(p)
        try:
            prepared.append((j, api._prepare(points, normals, finger, lines, kw)))
        except (DataError, InputError) as exc:
            results[j] = exc
    if prepared:
        n = max(len(prep.points) for _, prep in prepared)
        P = np.zeros((len(prepared), n, 3))
        N = np.zeros((len(prepared), n, 3))
        N[..., 2] = 1.0  # padding: finite and masked out
        mask = np.zeros((len(prepared), n), bool)
        for b, (_, prep) in enumerate(prepared):
            m = len(prep.points)
            P[b, :m], N[b, :m], mask[b, :m] = prep.points, prep.normals, True
        opts = prepared[0][1].opts
        noise = (opts["noise_pos"], opts["noise_normal"])
        fits = centre_jet.fit(P, N, mask, *noise, opts["max_normal_angle"])
        pre = api.outcome_inputs(fits, opts["grid"])
        lines = [prep.opts["lines"] for _, prep in prepared]
        for (j, prep), res in zip(prepared, api.jet_outcomes(fits, opts, pre, lines), strict=True):
            if not isinstance(res, DataError):
                res = api._result(
                    res, len(prep.points), "jet", maps, prep.breaks, prep.dropped, prep.middle
                )
            results[j] = res
    return results


def _one(p, kw):
    points, normals, finger, lines = _unpack(p)
    try:
        return api.analyze_patch(points, normals, finger=finger, lines=lines, **kw)
    except (DataError, InputError) as exc:
        return exc


def _defaults():
    """``analyze_patch``'s keyword defaults (one source: its signature)."""
    import inspect

    sig = inspect.signature(api.analyze_patch)
    skip = {"points", "normals", "finger", "lines"}
    return {k: v.default for k, v in sig.parameters.items() if k not in skip}
