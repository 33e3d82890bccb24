"""Many patches at once: ``analyze_patches``.

Each patch is prepared as ``analyze_patch`` prepares it (validation, duplicates, centring;
patches of one size together, ``_prepare_stacked``), the crease and tilt checks are
screened for each size at once (``check_screens``; only the patches not cleared run
``edges.check`` and ``tilt.untilt``), then a chunk of patches is fitted by
one ``local_jet.fit`` call on a padded stack with a row mask (the fit is batch-first: the
stack equals each patch alone, tested), and the analysis after the fit
(positions-versus-normals test, determination, intervals, label, grid statistics:
``jet_answers.outcomes``) runs on the whole stack too; only the assembly of each patch's
result is per patch.  The result per patch equals ``analyze_patch``'s to round-off; a
patch that is refused or malformed gives its exception in its place and the others still
come out.

Only the default method is batched; ``method="spline"`` falls back to one patch at a time.
"""

import numpy as np

from tactile.ep2 import (
    api,
    check_screens,
    edges,
    extent,
    jet_answers,
    local_jet,
    patch_frame,
    patch_input,
    tilt,
)
from tactile.errors import DataError, InputError

CHUNK = 256  # patches per fit call


def analyze_patches(patches, *, chunk=CHUNK, **kw):
    """[PatchResult or DataError/InputError] for ``patches``, an iterable of (points,
    normals) pairs or dicts with ``points``, ``normals`` and optionally ``finger``,
    ``lines``, ``noise_pos``, ``noise_normal`` (the patch's own, over the keyword's).
    Keyword options are ``analyze_patch``'s and apply to every patch.  Patches are read
    ``WINDOW`` chunks at a time and fitted in chunks of like size (less padding)."""
    out, todo = [], []
    for p in patches:
        todo.append(p)
        if len(todo) == chunk * WINDOW:
            out += _window(todo, chunk, kw)
            todo = []
    return out + (_window(todo, chunk, kw) if todo else [])


WINDOW = 16
STACK_ROWS = patch_input.MAX_ROWS  # rows of a padded stack (patches x the largest's rows)


def _window(patches, chunk, kw):
    """``_chunk`` over ``patches`` sorted by size, the results in the patches' order."""
    sizes = [_size(p) for p in patches]
    order = sorted(range(len(patches)), key=sizes.__getitem__)
    out = [None] * len(patches)
    for idx in stacks(order, sizes, chunk):
        for j, res in zip(idx, _chunk([patches[j] for j in idx], kw), strict=True):
            out[j] = res
    return out


def stacks(order, sizes, chunk, rows=STACK_ROWS):
    """``order`` (indices by ascending size) cut into stacks of at most ``chunk`` patches
    whose padded rows (count x the last's size) stay within ``rows``, or one patch alone:
    memory in proportion to the rows fitted, however unlike the patches' sizes."""
    out = []
    for j in order:
        if out and len(out[-1]) < chunk and (len(out[-1]) + 1) * sizes[j] <= rows:
            out[-1].append(j)
        else:
            out.append([j])
    return out


def _size(p):
    try:
        return len(_unpack(p)[0])
    except Exception:  # (malformed: ``_chunk`` says why, in its place)
        return 0


_OWN = ("noise_pos", "noise_normal")  # options a patch dict may set for itself


def _unpack(p):
    if isinstance(p, dict):
        return p["points"], p["normals"], p.get("finger"), p.get("lines")
    points, normals = p
    return points, normals, None, None


def _own(p, kw):
    """The options of patch ``p``: ``kw`` with the patch's own noise over it."""
    if not isinstance(p, dict) or not any(k in p for k in _OWN):
        return kw
    return {**kw, **{k: p[k] for k in _OWN if k in p}}


def _chunk(patches, kw):
    kw = patch_input.keywords(**kw)
    maps = kw.pop("maps")
    if kw["method"] == "spline":
        return [_one(p, dict(_own(p, kw), maps=maps)) for p in patches]
    prepared, results, tilted = [], [None] * len(patches), {}
    unpacked = [_unpack(p) for p in patches]
    kws = [_own(p, kw) for p in patches]
    quick = _prepare_stacked(unpacked, kws)
    preps = {}
    for j, (item, kw_j) in enumerate(zip(unpacked, kws, strict=True)):
        try:
            preps[j] = quick[j] or patch_input.prepare(*item, kw_j)
        except (DataError, InputError) as exc:
            results[j] = exc
    clear_edge, clear_tilt = _screens(preps)
    for j, prep in preps.items():
        try:
            if not clear_edge[j]:
                edges.check(prep)
            prep, tilted[j] = (prep, None) if clear_tilt[j] else tilt.untilt(prep)
            prepared.append((j, prep))
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
        noise = [[_nan(prep.opts[k]) for _, prep in prepared] for k in _OWN]
        stack = local_jet.fit(P, N, mask, *noise, opts["max_normal_angle"])
        lines = [prep.opts["names"] for _, prep in prepared]
        outcomes = jet_answers.outcomes(stack, opts, lines)
        for (j, prep), res in zip(prepared, outcomes, strict=True):
            try:
                edges.check_answer(prep, res)
            except DataError as exc:
                res = exc
            if not isinstance(res, DataError):
                res = api.from_fields(
                    res, len(prep.points), "jet", maps, prep.breaks, prep.dropped, prep.middle
                )
                res.warnings[:0] = [tilted[j]] if tilted[j] else []
            results[j] = res
    return results


def _screens(preps):
    """({j: bool}, {j: bool}): which prepared patches surely pass ``edges.check`` and are
    surely left as they are by ``tilt.untilt`` (``check_screens``, a stack per size)."""
    edge, tilted, groups = {}, {}, {}
    for j, prep in preps.items():
        groups.setdefault(len(prep.points), []).append(j)
    for idx in groups.values():
        P = np.stack([preps[j].points for j in idx])
        N = np.stack([preps[j].normals for j in idx])
        e, t = check_screens.clear(P, N, [preps[j].opts for j in idx])
        edge.update(zip(idx, e.tolist(), strict=True))
        tilted.update(zip(idx, t.tolist(), strict=True))
    return edge, tilted


def _nan(v):
    return np.nan if v is None else v


def _prepare_stacked(unpacked, kws):
    """``patch_input.prepare`` of every patch that passes its checks as it stands (valid options,
    finite, representable spread, non-zero normals, no duplicated rows), for each group of
    patches of one size at once; None for the others, which ``patch_input.prepare`` takes one at a
    time (it refuses them, or drops their duplicates).  The same numbers either way."""
    out = [None] * len(unpacked)
    groups, sound = {}, {}
    for j, (points, normals, _, _) in enumerate(unpacked):
        own = tuple(kws[j][k] for k in _OWN)
        if own not in sound:
            sound[own] = _sound_options(kws[j])
        pts, nrm = np.asarray(points, float), np.asarray(normals, float)
        if (
            sound[own]
            and len(pts) <= patch_input.MAX_ROWS
            and pts.ndim == 2
            and pts.shape[1] == 3
            and nrm.shape == pts.shape
            and len(pts)
        ):
            groups.setdefault(len(pts), []).append((j, pts, nrm))
    for group in groups.values():
        idx = [j for j, _, _ in group]
        for k, prep in zip(
            idx, _prepare_group(group, unpacked, [kws[j] for j in idx]), strict=True
        ):
            out[k] = prep
    return out


def _sound_options(kw):
    """Whether the options hold for any patch (else the one-patch path says why not)."""
    try:
        patch_input.validate(np.zeros((1, 3)), np.ones((1, 3)), kw["method"], kw["weighting"])
        patch_input.check_options(np.zeros((1, 3)), None, *(kw[k] for k in _CONSTANT_OPTIONS))
        patch_input.check_order(kw["method"], kw["order"])
        if kw["noise_pos"] is not None and not np.isfinite(float(kw["noise_pos"])):
            return False
    except (DataError, InputError, TypeError, ValueError):
        return False
    return True


_CONSTANT_OPTIONS = ("noise_normal", "grid", "segments", "max_normal_angle", "break_angle")


def _prepare_group(group, unpacked, kws):
    """``_prepare_stacked`` for patches of one size (their options ``kws``): [Prepared or None]."""
    P = np.stack([pts for _, pts, _ in group])
    N = np.stack([nrm for _, _, nrm in group])
    good = np.all(np.isfinite(P), axis=(1, 2)) & np.all(np.isfinite(N), axis=(1, 2))
    lo, hi = P.min(axis=1), P.max(axis=1)  # ``extent.box``
    h = (0.5 * hi - 0.5 * lo).max(axis=-1)
    good &= (h == 0.0) | ((extent.MIN_SPREAD <= 2.0 * h) & (2.0 * h <= extent.MAX_SPREAD))
    noise = np.array([np.nan if kw["noise_pos"] is None else kw["noise_pos"] for kw in kws])
    top = patch_input.MAX_NOISE_SPREADS * 2.0 * np.where(good, h, 0.0)  # a wild patch: not here
    good &= np.isnan(noise) | ((noise >= 0.0) & (noise <= top))
    N, ok = patch_frame.unit_rows(N)
    good &= np.all(ok, axis=-1)
    good &= ~_has_duplicates(P, N)
    middle = 0.5 * lo + 0.5 * hi  # ``extent.centred``
    P = P - middle[:, None, :]
    out = [None] * len(group)
    live = np.flatnonzero(good)
    fingers = [unpacked[group[b][0]][2] for b in live.tolist()]
    breaks = patch_input.find_breaks(N[live], fingers, kws[0]["break_angle"])
    for b, brk in zip(live.tolist(), breaks, strict=True):
        lines = unpacked[group[b][0]][3]
        opts = dict(patch_input.options(kws[b], lines), names=patch_input.row_names(lines))
        out[b] = patch_input.Prepared(P[b], N[b], opts, brk, 0, middle[b])
    return out


def _has_duplicates(P, N):
    """(G,) whether a patch repeats a row exactly (``patch_input._drop_duplicates`` drops them).
    Only a patch with two equal x (or a non-finite number) can: the rows of those alone are
    compared whole."""
    x = np.sort(P[..., 0], axis=-1)
    maybe = np.any(x[:, 1:] == x[:, :-1], axis=-1)
    maybe |= ~(np.all(np.isfinite(P), axis=(1, 2)) & np.all(np.isfinite(N), axis=(1, 2)))
    out = np.zeros(len(P), bool)
    if maybe.any():
        out[maybe] = _repeats(P[maybe], N[maybe])
    return out


def _repeats(P, N):
    """``_has_duplicates`` by comparing whole rows (a sort of every row of the stack)."""
    G, n, _ = P.shape
    patch = np.repeat(np.arange(G, dtype=float), n)[:, None]
    rows = np.concatenate([patch, P.reshape(-1, 3), N.reshape(-1, 3)], axis=1)
    rows = rows[np.all(np.isfinite(rows), axis=1)]
    distinct = np.unique(rows, axis=0)[:, 0].astype(int)
    return np.bincount(distinct, minlength=G) < n


def _one(p, kw):
    points, normals, finger, lines = _unpack(p)
    try:
        return api.analyze_patch(points, normals, finger=finger, lines=lines, **kw)
    except (DataError, InputError) as exc:
        return exc
