"""EP2 in one call: contacts and normals in, curvature at the patch centre with a label out.

``analyze_patch(points, normals)`` runs the thesis's algorithm (§4.1) with the
default estimator ``method="jet"`` (``centre_jet``, ``centre_result``): a local
jet about the patch centre whose model (quadric, or the closed form exact for
spheres and cylinders) the data choose, curvature reported AT THE CENTRE with
95 % intervals, refused (``DataError``) where the data do not determine it or
where positions and normals disagree.  ``method="spline"`` is the thesis's
B-spline patch (``spline_analysis``), kept to reproduce chapters 4-5.

One definition everywhere (table, JSON, plots): ``S``, ``k1``, ``k2``,
``radius`` and ``C`` are at the patch centre (the middle of the contacts'
bounding box in the patch frame); ``S_mean``, ``S_std``, ``R_mean``,
``C_mean``, ``k1_mean`` ... are the thesis's statistics over the N x N grid
(§4.8.2).  Lengths are in the input unit, curvatures in 1/unit.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import (
    agreement,
    centre_jet,
    centre_result,
    discontinuity,
    extent,
    grid_batch,
    jet_basis,
    patch_frame,
)
from tactile.ep2.centre_result import hk_eps
from tactile.ep2.shape_index import hk_labels
from tactile.ep2.surface_geometry import principal
from tactile.errors import DataError, InputError

METHODS = ("jet", "spline")
MAX_GRID = 256  # analysis grid N x N: memory grows as N^2
MAX_SEGMENTS = 64  # spline segments per direction
MAX_NOISE_SPREADS = 1e6  # a position noise beyond this many spreads leaves no shape to fit
WEIGHTINGS = ("auto", "tangent", "position")
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


def analyze_patch(
    points,
    normals,
    *,
    method="jet",
    order=None,
    segments=1,
    weighting="auto",
    noise_pos=None,
    noise_normal=None,
    grid=8,
    align=False,
    solver="svd",
    max_normal_angle=patch_frame.MAX_NORMAL_ANGLE_DEG,
    shrink=None,
    intervals=True,
    finger=None,
    break_angle=discontinuity.BREAK_ANGLE_DEG,
    lines=None,
    maps=False,
):
    """Fit and analyse one patch of contacts (world frame) with outward normals.

    points, normals: (n, 3), normals pointing from the object toward the finger.
    ``method`` "jet" (default) or "spline" (the thesis's B-spline; ``order``
    2-4 per direction, default 2, ``segments``, ``weighting`` "tangent" /
    "position" 100:1 as in §4.9 or "auto", ``align``, ``solver``, ``shrink``
    apply to it alone).  ``noise_pos`` (input unit) and ``noise_normal`` (rad)
    state the noise; what is not stated is estimated.  ``finger`` (one label
    per row, sweep order) enables the discontinuity check (§6.2.5);
    ``lines`` (CSV line per row) names rows in messages; ``maps`` keeps the
    grid maps (fig. 50).

    Raises ``InputError`` for malformed input and ``DataError`` when the
    contacts do not determine the curvature (the message says why).
    """
    kw = dict(
        method=method, order=order, segments=segments, weighting=weighting,
        noise_pos=noise_pos, noise_normal=noise_normal, grid=grid, align=align, solver=solver,
        max_normal_angle=max_normal_angle, shrink=shrink, intervals=intervals,
        break_angle=break_angle,
    )  # fmt: skip
    prep = _prepare(points, normals, finger, lines, kw)
    pts, nrm, opts = prep.points, prep.normals, prep.opts
    if method == "spline":
        from tactile.ep2 import spline_analysis

        out = spline_analysis.analyze(pts, nrm, opts)
    else:
        out = _analyze_jet(pts, nrm, opts)
    return _result(out, len(pts), method, maps, prep.breaks, prep.dropped, prep.middle)


@dataclass
class Prepared:
    """One patch ready to fit: validated, duplicates dropped, centred (``analyze_patch``)."""

    points: np.ndarray
    normals: np.ndarray
    opts: dict
    breaks: list
    dropped: int
    middle: np.ndarray


def _prepare(points, normals, finger, lines, kw):
    """Validation and the steps before the fit, shared by one patch and a batch."""
    method, weighting, order = kw["method"], kw["weighting"], kw["order"]
    noise_pos, noise_normal = kw["noise_pos"], kw["noise_normal"]
    pts, nrm = _validate(points, normals, method, weighting, lines)
    _check_options(
        pts, noise_pos, noise_normal, kw["grid"], kw["segments"], kw["max_normal_angle"],
        kw["break_angle"],
    )  # fmt: skip
    pts, nrm, finger, lines, dropped = _drop_duplicates(pts, nrm, finger, lines)
    pts, middle = extent.centred(pts)  # the frame's origin moves back in ``_result``
    breaks = discontinuity.find_breaks(nrm, finger, kw["break_angle"])
    _check_order(method, order)
    return Prepared(pts, nrm, _opts(kw, lines), breaks, dropped, middle)


def _check_order(method, order):
    if method != "spline" and order not in (None, centre_jet.ORDER):
        raise InputError(f"the jet order is {centre_jet.ORDER}; --order is for method spline")


def _opts(kw, lines):
    """The options the methods read, from ``analyze_patch``'s keywords and a patch's lines."""
    keys = "segments weighting noise_pos noise_normal grid align solver max_normal_angle shrink"
    out = {"order": 2 if kw["order"] is None else kw["order"]}
    out.update({k: kw[k] for k in keys.split()}, intervals=kw["intervals"], lines=lines)
    return out


def _analyze_jet(pts, nrm, opts):
    mask = np.ones((1, len(pts)), bool)
    noise = (opts["noise_pos"], opts["noise_normal"])
    fits = centre_jet.fit(pts[None], nrm[None], mask, *noise, opts["max_normal_angle"])
    (out,) = jet_outcomes(fits, opts, outcome_inputs(fits, opts["grid"]), [opts["lines"]])
    if isinstance(out, DataError):
        raise out
    return out


@dataclass
class OutcomeInputs:
    """What ``jet_outcomes`` needs of a whole ``centre_jet.fit`` stack, computed for the
    stack at once (``outcome_inputs``): Cov widening, the contacts' spread, the grid."""

    widen: np.ndarray
    spread: tuple
    grid: tuple
    stats: dict
    direction1: np.ndarray


def outcome_inputs(fits, n_grid):
    """``OutcomeInputs`` of every patch of ``fits`` (an N x N grid)."""
    ch, gx, gy = grid_batch.channels(fits.coef, fits.model, fits.xy, fits.mask, n_grid)
    zx, zy, zxx, zxy, zyy = (fits.coef[:, k] for k in jet_basis.CHANNELS)
    d1 = np.asarray(principal(zx, zy, zxx, zxy, zyy)["dir1"], float)
    return OutcomeInputs(
        widen=centre_result.widen(fits.dof),
        spread=centre_result.spread_eigen(fits.xyz_mean, fits.mask),
        grid=(ch, gx, gy),
        stats=grid_batch.statistics(ch, fits.scale),
        direction1=np.einsum("bi,bij->bj", d1, fits.axes),
    )


def jet_outcomes(fits, opts, pre, lines=None):
    """The analysis of every patch of a ``centre_jet.fit`` stack: a list of field dicts, or
    the ``DataError`` that refuses a patch in its place.  ``pre`` = ``outcome_inputs`` of the
    stack; ``lines`` per patch (its CSV line per row, or None) name rows in messages.  The
    tests, intervals and labels run on the whole stack at once; only the assembly of each
    patch's fields is per patch."""
    lines = [None] * len(fits.reason) if lines is None else lines
    out = [None] * len(fits.reason)
    live = []
    for i, why in enumerate(fits.reason):
        if why is None:
            live.append(i)
        else:
            out[i] = DataError(_name_rows(why, lines[i]))
    idx = np.array(live, int)
    if not live:
        return out
    split = tuple((d[idx], c[idx], (z[0][idx], z[1][idx])) for d, c, z in fits.split)
    checks = agreement.consistency(split, fits.dof[idx], fits.scale[idx], fits.axes[idx])
    cov = fits.cov[idx] * pre.widen[idx][:, None, None]
    spread = tuple(v[idx] for v in pre.spread), fits.mean_axes[idx]
    undetermined = centre_result.determination_many(
        cov, fits.axes[idx], fits.scale[idx], spread, fits.noise[idx, 0]
    )
    ok = []
    for k, i in enumerate(live):
        refusal = checks[k][0] or undetermined[k]
        if refusal is not None:
            out[i] = DataError(refusal)
        else:
            ok.append(k)
    ok = np.array(ok, int)
    # a mild disagreement: intervals about the joint estimate that reach both sides' (gap/2
    # as one more sd in its direction: with the 95 % radius, about the whole gap)
    gap = np.array([checks[k][2] for k in ok]).reshape(-1, 3)
    j = idx[ok]
    heads = centre_result.summary_many(
        fits.t[j], cov[ok] + gap[:, :, None] * gap[:, None, :] / 4, fits.bias[j],
        fits.scale[j], opts["intervals"], fits.cov_noise[j],
    )  # fmt: skip
    for k, i, head in zip(ok, j, heads, strict=True):
        head["warnings"] = [] if checks[k][1] is None else [checks[k][1]]
        out[i] = _jet_fields(fits, i, head, pre)
    return out


def _name_rows(why, lines):
    """A refusal naming 'contact k' names its CSV line instead, where lines are known."""
    if lines is not None and "contact " in why:
        k = int(why.split("contact ")[1].split()[0])
        why = why.replace(f"contact {k} ", f"line {lines[k]} ")
    return why


def _jet_fields(fits, i, out, pre):
    """Patch ``i``'s result fields: ``out`` (its ``summary``) and what the fit holds."""
    L, axes = float(fits.scale[i]), fits.axes[i]
    coef, model, xy = fits.coef[i], int(fits.model[i]), fits.xy[i][fits.mask[i]]
    out.update(grid_batch.at(pre.stats, i, L, out["shape"] == "plane"))
    ch, gx, gy = pre.grid
    out.update(
        order=centre_jet.ORDER,
        weighting="auto" if not any(fits.stated) else "stated",
        model=_model_text(fits.score[i], model),
        noise_pos=float(fits.noise[i, 0]),
        noise_normal=float(fits.noise[i, 1]),
        frame=patch_frame.PatchFrame(fits.origin[i], axes),
        scale=L,
        surface=lambda q: _jet_height(coef, model, q),
        grid=([c[i] for c in ch], gx[i], gy[i]),
        direction1=pre.direction1[i],
        box=(xy[:, 0].min(), xy[:, 0].max(), xy[:, 1].min(), xy[:, 1].max()),
    )
    return out


def _jet_height(coef, model, xy):
    z = jet_basis.design(xy[:, 0], xy[:, 1], jet_basis.order_of(len(coef)), ((0, 0),)) @ coef
    if model == 1:
        z = z + jet_basis.round_excess(xy[:, 0], xy[:, 1], jet_basis.hessian(coef))[0]
    return z


def _model_text(score, model):
    """One line: which model and why (its AIC lead over the runner-up, ``centre_jet``)."""
    names = {0: "quadric 3-jet", 1: "round 3-jet (sphere/cylinder closed form)"}
    score = np.asarray(score, float)
    rest = [k for k in range(len(score)) if k != model and np.isfinite(score[k])]
    if not rest:
        return f"{names[model]}: the only model that fits"
    runner = min(rest, key=lambda k: score[k])
    lead = float(score[runner] - score[model])
    return f"{names[model]}: chi2 + 2 dof {lead:.3g} below the {names[runner]}"


def _result(out, n, method, maps, breaks, dropped, middle):
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
        hk_label=str(hk_labels(np.array([K]), np.array([H]), *eps)[0]),
        direction1=direction,
        order=out["order"],
        weighting=out["weighting"],
        noise_pos=out["noise_pos"],
        noise_normal=out["noise_normal"],
        votes=out["votes"],
        warnings=warnings,
        discontinuities=breaks,
        maps=grid_maps,
        frame=patch_frame.PatchFrame(out["frame"].origin + middle, out["frame"].rot),
        scale=L,
        surface_fn=out["surface"],
        fit=out.get("fit"),
        box=box,
    )


def _validate(points, normals, method, weighting, lines=None):
    if method not in METHODS:
        raise InputError(f"unknown method {method!r} (choose {', '.join(METHODS)})")
    if weighting not in WEIGHTINGS:
        raise InputError(f"unknown weighting {weighting!r} (choose {', '.join(WEIGHTINGS)})")
    if method == "jet" and weighting != "auto":
        raise InputError(f"weighting {weighting!r} is the thesis's: use it with method 'spline'")
    pts = np.asarray(points, float)
    nrm = np.asarray(normals, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or nrm.shape != pts.shape:
        raise InputError(f"points and normals must both be (n, 3); got {pts.shape} and {nrm.shape}")
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(nrm))):
        raise InputError("points and normals must be finite numbers")
    problem = extent.spread_problem(pts)
    if problem is not None:
        row, axis, why = problem
        at = f"contact {row}" if lines is None else f"line {lines[row]}"
        raise InputError(f"{at}: column '{extent.AXES[axis]}': {why}")
    return pts, patch_frame.unit_normals(nrm)


def _check_options(pts, noise_pos, noise_normal, grid, segments, max_angle, break_angle):
    """Numbers the fit can use, or ``InputError`` naming the keyword and its CLI option."""

    def refuse(name, rule, value):
        option = "--" + name.replace("_", "-")
        return InputError(f"{name} ({option}): must be {rule}, got {value!r}")

    top = MAX_NOISE_SPREADS * 2.0 * float(extent.box(pts)[1].max())
    if noise_pos is not None and not 0.0 <= noise_pos <= top:
        rule = f"a number >= 0 and at most {MAX_NOISE_SPREADS:g} contact spreads ({top:.3g})"
        raise refuse("noise_pos", rule, noise_pos)
    if noise_normal is not None and not 0.0 <= noise_normal <= np.pi:
        raise refuse("noise_normal", "a number of rad in [0, pi]", noise_normal)
    if not 0.0 < max_angle <= 90.0:
        raise refuse("max_normal_angle", "a number of deg in (0, 90]", max_angle)
    if not 0.0 <= break_angle <= 180.0:
        raise refuse("break_angle", "a number of deg in [0, 180]", break_angle)
    if not 2 <= grid <= MAX_GRID:
        raise refuse("grid", f"a whole number in 2..{MAX_GRID}", grid)
    if not all(1 <= n <= MAX_SEGMENTS for n in np.atleast_1d(segments)):
        raise refuse("segments", f"a whole number in 1..{MAX_SEGMENTS}", segments)


def _drop_duplicates(pts, nrm, finger, lines):
    """Rows repeated exactly (same position and normal) carry no new information: keep the
    first of each, so they cannot narrow the intervals.  Returns the count dropped."""
    rows = np.column_stack([pts, nrm])
    _, first = np.unique(rows, axis=0, return_index=True)
    if first.size == len(rows):
        return pts, nrm, finger, lines, 0
    keep = np.sort(first)
    finger = None if finger is None else [finger[i] for i in keep]
    lines = None if lines is None else [lines[i] for i in keep]
    return pts[keep], nrm[keep], finger, lines, len(rows) - keep.size


def analyze_sweep(points, normals, finger=None, split=False, **kw):
    """Like ``analyze_patch``; with ``split`` a sweep broken by discontinuities
    (§6.2.5) is cut into parts analysed separately.  Returns a list of results."""
    nrm = patch_frame.unit_normals(np.asarray(normals, float))
    breaks = discontinuity.find_breaks(
        nrm, finger, kw.get("break_angle", discontinuity.BREAK_ANGLE_DEG)
    )
    if not (split and breaks):
        return [analyze_patch(points, normals, finger=finger, **kw)]
    parts = discontinuity.split_parts(len(nrm), finger, breaks)
    pts = np.asarray(points, float)
    fing = np.asarray(finger)
    lines = kw.pop("lines", None)
    out = []
    for rows in parts:
        sub_lines = None if lines is None else [lines[i] for i in rows]
        out.append(analyze_patch(pts[rows], nrm[rows], finger=fing[rows], lines=sub_lines, **kw))
    return out
