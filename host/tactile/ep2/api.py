"""EP2 in one call: contacts and normals in, curvature at the patch centre with a label out.

``analyze_patch(points, normals)`` runs the thesis's algorithm (§4.1) with the
default estimator ``method="jet"`` (``local_jet``, ``jet_answers``): jets of
positions and normals about the patch centre, the 2-jet moved toward the 3-jet on
evidence, bad contacts left out by name, curvature reported AT THE CENTRE with
95 % intervals that count the model's truncation, refused (``DataError``) where
the data do not determine it or where positions and normals disagree.
``method="spline"`` is the thesis's B-spline patch (``spline``), kept to
reproduce chapters 4-5.

One definition everywhere (table, JSON, plots): ``S``, ``k1``, ``k2``,
``radius`` and ``C`` are at the patch centre (the middle of the contacts'
bounding box in the patch frame); ``S_mean``, ``S_std``, ``R_mean``,
``C_mean``, ``k1_mean`` ... are the thesis's statistics over the N x N grid
(§4.8.2).  Lengths are in the input unit, curvatures in 1/unit.

The steps: ``patch_input`` (validation, duplicates, centring), ``local_jet`` (the fit),
``jet_answers`` (refusals, positions against normals, intervals, labels), and here the
``PatchResult`` (its JSON record, and its assembly from the method's fields).

Many patches at once, ``analyze_patches``: each is prepared as ``analyze_patch`` prepares
it (patches of one size together, ``_prepare_stacked``), the crease and tilt checks are
screened for each size at once (``check_screens``; only the patches not cleared run
``edges.check`` and ``tilt.untilt``), then a chunk is fitted by one ``local_jet.fit`` call
on a padded stack with a row mask, and ``jet_answers.outcomes`` runs on the whole stack;
only the assembly of each result is per patch.  Each result equals ``analyze_patch``'s to
round-off (tested); a patch that is refused or malformed gives its exception in its place
and the others still come out.  ``method="spline"`` runs one patch at a time.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import (
    centre_result,
    check_screens,
    edges,
    geometry,
    jet_answers,
    local_jet,
    patch_input,
    tilt,
)
from tactile.ep2.centre_result import hk_eps
from tactile.ep2.geometry import hk_labels
from tactile.errors import DataError, InputError

__all__ = ["PatchResult", "analyze_patch", "analyze_patches", "analyze_sweep"]


def analyze_patch(
    points, normals, *, method="jet", jet=None, spline=None, finger=None, lines=None,
    maps=False, **options,
):  # fmt: skip
    """Fit and analyse one patch of contacts (world frame) with outward normals.

    points, normals: (n, 3), normals pointing from the object toward the finger.
    ``method`` "jet" (default) or "spline" (the thesis's B-spline).  ``jet``
    (``JetOptions``) holds the options both methods read: ``noise_pos`` (input
    unit) and ``noise_normal`` (rad) state the noise, what is not stated is
    estimated; ``max_normal_angle``, ``break_angle``, ``grid``, ``intervals``.
    ``spline`` (``SplineOptions``) holds the spline's own: ``order`` 2-4 per
    direction (default 2), ``segments``, ``weighting`` "tangent" / "position"
    100:1 as in §4.9 or "auto", ``align``, ``solver``, ``shrink``.  Any of them
    may be given by name instead (``noise_pos=0.01``, ``order=3``), over the
    dataclasses.  ``finger`` (one label per row, sweep order) enables the
    discontinuity check (§6.2.5); ``lines`` (CSV line per row) names rows in
    messages; ``maps`` keeps the grid maps (fig. 50).

    Raises ``InputError`` for malformed input and ``DataError`` when the
    contacts do not determine the curvature (the message says why).
    """
    kw = patch_input.keywords(method, jet, spline, maps, **options)
    prep = patch_input.prepare(points, normals, finger, lines, kw)
    edges.check(prep)
    prep, tilted = tilt.untilt(prep)
    pts, nrm, opts = prep.points, prep.normals, prep.opts
    if method == "spline":
        from tactile.ep2 import spline  # (start-up: scipy only for the spline)

        out = spline.analyze(pts, nrm, opts)
    else:
        out = _analyze_jet(pts, nrm, opts)
    edges.check_answer(prep, out)
    if isinstance(out, DataError):
        raise out
    res = from_fields(out, len(pts), method, maps, prep.breaks, prep.dropped, prep.middle)
    res.warnings[:0] = [tilted] if tilted else []
    return res


def _analyze_jet(pts, nrm, opts):
    mask = np.ones((1, len(pts)), bool)
    stack = local_jet.fit(
        pts[None],
        nrm[None],
        mask,
        opts["noise_pos"],
        opts["noise_normal"],
        opts["max_normal_angle"],
    )
    (out,) = jet_answers.outcomes(stack, opts, [opts["names"]])
    return out  # or the DataError refusing it


def analyze_sweep(points, normals, finger=None, split=False, **kw):
    """Like ``analyze_patch``; with ``split`` a sweep broken by discontinuities
    (§6.2.5) is cut into parts analysed separately.  Returns a list of results."""
    lines = kw.pop("lines", None)
    kw = patch_input.keywords(**kw)
    parts = sweep_parts(points, normals, finger, lines, split, kw)
    if parts is None:
        return [analyze_patch(points, normals, finger=finger, lines=lines, **kw)]
    return [
        analyze_patch(p["points"], p["normals"], finger=p["finger"], lines=p["lines"], **kw)
        for p in parts
    ]


def sweep_parts(points, normals, finger, lines, split, kw):
    """The parts ``analyze_sweep`` fits (dicts of points, normals, finger, lines, as
    ``analyze_patches`` takes them), or None when it fits the patch whole (no ``split``, or
    no break).  Raises as ``analyze_sweep`` does for normals it cannot use."""
    nrm = geometry.unit_normals(np.asarray(normals, float))
    (breaks,) = patch_input.find_breaks(
        nrm[None], [finger], kw.get("break_angle", patch_input.BREAK_ANGLE_DEG)
    )
    if not (split and breaks):
        return None
    pts, fing = np.asarray(points, float), np.asarray(finger)
    return [
        {
            "points": pts[rows],
            "normals": nrm[rows],
            "finger": fing[rows],
            "lines": None if lines is None else [lines[i] for i in rows],
        }
        for rows in patch_input.split_parts(len(nrm), finger, breaks)
    ]


# --- What ``analyze_patch`` returns: ``PatchResult``, its JSON record, and its assembly from the
# method's fields (``from_fields``: direction, HK label, warnings, maps).
#
# One definition everywhere (table, JSON, plots): ``S``, ``k1``, ``k2``, ``radius`` and ``C`` are
# at the patch centre; ``S_mean``, ``S_std`` ... are the grid statistics (§4.8.2).


JSON_KEYS = (
    "n_points method model shape confidence S k1 k2 radius C S_interval k1_interval k2_interval"
    " radius_interval S_mean S_std R_mean R_std C_mean k1_mean k2_mean k1_std k2_std hk_label"
    " direction1 order weighting noise_pos noise_normal votes warnings"
).split()


@dataclass
class PatchResult:
    """Everything ``analyze_patch`` found.  ``to_dict`` gives the JSON record."""

    n_points: int
    method: str
    model: str  # which model was fitted and why, in one line
    shape: str
    confidence: float
    S: float | None  # at the patch centre
    k1: float
    k2: float
    radius: float | None
    C: float | None
    S_interval: tuple | None
    k1_interval: tuple | None
    k2_interval: tuple | None
    radius_interval: tuple | None
    S_mean: float | None  # grid statistics (thesis, §4.8.2)
    S_std: float | None
    R_mean: float
    R_std: float
    C_mean: float | None
    k1_mean: float
    k2_mean: float
    k1_std: float
    k2_std: float
    hk_label: str
    direction1: np.ndarray
    order: int
    weighting: str
    noise_pos: float | None  # used for the weights: stated or estimated (input unit)
    noise_normal: float | None  # (rad)
    votes: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    discontinuities: list = field(default_factory=list)
    maps: dict = field(default_factory=dict, repr=False)
    frame: object = field(default=None, repr=False)  # patch frame of ``surface``
    scale: float = 1.0
    surface_fn: object = field(default=None, repr=False)  # z(xy / scale) / scale
    fit: object = field(default=None, repr=False)  # the B-spline fit (method "spline")
    box: tuple = field(default=None, repr=False)  # contacts' box in the patch frame / scale

    def to_dict(self, patch=None):
        out = {"patch": patch} if patch is not None else {}
        out.update({k: getattr(self, k) for k in JSON_KEYS})
        out["discontinuities"] = [
            {"row": r, "finger": f, "angle_deg": a} for r, f, a in self.discontinuities
        ]
        return out

    def surface(self, xy_patch):
        """Fitted z (patch frame, input units) at patch-frame (x, y) rows."""
        xy = np.asarray(xy_patch, float) / self.scale
        return self.surface_fn(xy) * self.scale

    def surface_world(self, xy_patch):
        """Fitted surface points mapped back to the input (world) frame."""
        xy = np.asarray(xy_patch, float)
        return self.frame.to_world(np.column_stack([xy, self.surface(xy)]))

    def control_net(self):
        """Control points (nx, ny, 3) of a B-spline fit, patch frame, input units (§4.6); None
        for the jet, which has none.  x, y are the knot vectors' Greville abscissae."""
        if self.fit is None:
            return None
        fit, d = self.fit, self.fit.domain
        kx, ky = fit.degree
        gu, gv = (
            np.array([np.mean(t[i + 1 : i + k + 1]) for i in range(len(t) - k - 1)])
            for t, k in ((fit.tx, kx), (fit.ty, ky))
        )
        cx, cy = np.meshgrid(d.x0 + d.hx * gu, d.y0 + d.hy * gv, indexing="ij")
        cz = np.reshape(fit.coef, cx.shape)
        return np.stack([cx, cy, cz], axis=-1) * self.scale

    def domain_box(self):
        """(x_min, x_max, y_min, y_max) of the contacts in the patch frame, input units."""
        return tuple(v * self.scale for v in self.box)


def from_fields(out, n, method, maps, breaks, dropped, middle):
    """PatchResult from the method's fields: direction, HK label, warnings, maps."""
    L = out["scale"]
    # HK label in units of the patch (K of 1/L^2 leaves the float range beyond L ~ 1e+-154)
    k1, k2 = out["k1"] * L, out["k2"] * L
    iv1, iv2 = (
        None if v is None else tuple(x * L for x in v)
        for v in (out["k1_interval"], out["k2_interval"])
    )
    eps = hk_eps(iv1, iv2, k1, k2)
    K, H = k1 * k2, 0.5 * (k1 + k2)
    warnings = [f"{dropped} duplicated row(s) counted once"] if dropped else []
    warnings += out.get("warnings", [])
    warnings += [f"normals turn {a:.0f} deg at row {r} (finger {f})" for r, f, a in breaks]
    grid_maps = {}
    if maps:
        channels, gx, gy = out["grid"]
        grid_maps = centre_result.maps(channels, gx, gy, L, out["shape"] == "plane", eps)
    direction = out.get("direction1")
    if direction is None:
        direction = out["frame"].to_world_dirs(out["direction1_patch"])
    box = out.get("box")
    if box is None:
        d = out["fit"].domain
        box = (d.x0, d.x0 + d.hx, d.y0, d.y0 + d.hy)
    return PatchResult(
        n_points=n,
        method=method,
        **{k: out[k] for k in ("model", "shape", "confidence", "S", "k1", "k2", "radius", "C")},
        **{k: out[k] for k in ("S_interval", "k1_interval", "k2_interval", "radius_interval")},
        **{k: out[k] for k in ("S_mean", "S_std", "R_mean", "R_std", "C_mean")},
        **{k: out[k] for k in ("k1_mean", "k2_mean", "k1_std", "k2_std")},
        hk_label=str(hk_labels(np.array(K), np.array(H), *eps)[()]),
        direction1=direction,
        order=out["order"],
        weighting=out["weighting"],
        noise_pos=out["noise_pos"],
        noise_normal=out["noise_normal"],
        votes=out["votes"],
        warnings=warnings,
        discontinuities=breaks,
        maps=grid_maps,
        frame=geometry.PatchFrame(out["frame"].origin + middle, out["frame"].rot),
        scale=L,
        surface_fn=out["surface"],
        fit=out.get("fit"),
        box=box,
    )


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
                res = from_fields(
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
    middle, half = patch_input.box(P)
    h = half.max(axis=-1)
    good &= (h == 0.0) | ((patch_input.MIN_SPREAD <= 2.0 * h) & (2.0 * h <= patch_input.MAX_SPREAD))
    noise = np.array([np.nan if kw["noise_pos"] is None else kw["noise_pos"] for kw in kws])
    top = patch_input.MAX_NOISE_SPREADS * 2.0 * np.where(good, h, 0.0)  # a wild patch: not here
    good &= np.isnan(noise) | ((noise >= 0.0) & (noise <= top))
    N, ok = geometry.unit_rows(N)
    good &= np.all(ok, axis=-1)
    good &= ~_has_duplicates(P, N)
    P = P - middle[:, None, :]  # ``patch_input.centred``
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
        return analyze_patch(points, normals, finger=finger, lines=lines, **kw)
    except (DataError, InputError) as exc:
        return exc
