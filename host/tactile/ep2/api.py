"""EP2 in one call: contacts and normals in, curvature at the patch centre with a label out.

``analyze_patch(points, normals)`` runs the thesis's algorithm (§4.1) with the
default estimator ``method="jet"`` (``local_jet``, ``jet_answers``): jets of
positions and normals about the patch centre, the 2-jet moved toward the 3-jet on
evidence, bad contacts left out by name, curvature reported AT THE CENTRE with
95 % intervals that count the model's truncation, refused (``DataError``) where
the data do not determine it or where positions and normals disagree.
``method="spline"`` is the thesis's B-spline patch (``spline_answers``), kept to
reproduce chapters 4-5.

One definition everywhere (table, JSON, plots): ``S``, ``k1``, ``k2``,
``radius`` and ``C`` are at the patch centre (the middle of the contacts'
bounding box in the patch frame); ``S_mean``, ``S_std``, ``R_mean``,
``C_mean``, ``k1_mean`` ... are the thesis's statistics over the N x N grid
(§4.8.2).  Lengths are in the input unit, curvatures in 1/unit.

The steps: ``patch_input`` (a ``Request`` of options, validation, duplicates, centring: a
``Prepared``), ``edges`` and ``tilt`` (checks), ``local_jet`` (the fit: a ``JetStack``),
``jet_answers`` or ``spline_answers`` (refusals, intervals, labels: an ``Answer``), and
here the ``PatchResult`` (its JSON record, and its assembly from the ``Answer``).  Many
patches at once: ``batch.analyze_patches``.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import edges, geometry, jet_answers, local_jet, patch_input, tilt
from tactile.ep2.geometry import (
    curvedness_c,
    curvedness_r,
    eigen,
    hk_label,
    hk_labels,
    s_region_map,
    shape_entries,
    shape_index,
)
from tactile.errors import DataError

__all__ = ["PatchResult", "analyze_patch", "analyze_sweep"]


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
    req = patch_input.keywords(method, jet, spline, maps, **options)
    prep = patch_input.prepare(points, normals, finger, lines, req)
    edges.check(prep)
    prep, tilted = tilt.untilt(prep)
    if method == "spline":
        from tactile.ep2 import spline_answers  # (start-up: scipy only for the spline)

        out = spline_answers.analyze(prep, req.spline)
    else:
        mask = np.ones((1, len(prep.points)), bool)
        jet = prep.jet
        stack = local_jet.fit(prep.points[None], prep.normals[None], mask, jet.noise_pos,
                              jet.noise_normal, jet.max_normal_angle)  # fmt: skip
        (out,) = jet_answers.outcomes(stack, jet, [prep.names])  # (or the DataError)
    edges.check_answer(prep, out)
    if isinstance(out, DataError):
        raise out
    return PatchResult.of(out, prep, method, maps, tilted)


def analyze_sweep(points, normals, finger=None, split=False, **kw):
    """Like ``analyze_patch``; with ``split`` a sweep broken by discontinuities
    (§6.2.5) is cut into parts analysed separately.  Returns a list of results."""
    lines = kw.pop("lines", None)
    req = patch_input.keywords(**kw)
    parts = sweep_parts(points, normals, finger, lines, split, req.jet.break_angle)
    if parts is None:
        return [analyze_patch(points, normals, finger=finger, lines=lines, **req.keywords())]
    return [
        analyze_patch(p["points"], p["normals"], finger=p["finger"], lines=p["lines"],
                      **req.keywords())
        for p in parts
    ]  # fmt: skip


# --- A sweep cut at its discontinuities (§6.2.5): ``split_parts`` cuts every finger's sequence
# at its breaks (``patch_input.find_breaks``) and groups the k-th piece of each finger into part
# k, so each part can be fitted as its own patch.


def sweep_parts(points, normals, finger, lines, split, break_angle=patch_input.BREAK_ANGLE_DEG):
    """The parts ``analyze_sweep`` fits (dicts of points, normals, finger, lines, as
    ``batch.analyze_patches`` takes them), or None when it fits the patch whole (no
    ``split``, or no break).  Raises as ``analyze_sweep`` does for normals it cannot use."""
    nrm = geometry.unit_normals(np.asarray(normals, float))
    (breaks,) = patch_input.find_breaks(nrm[None], [finger], break_angle)
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
        for rows in split_parts(len(nrm), finger, breaks)
    ]


def split_parts(n_rows, finger, breaks):
    """Row-index arrays of the parts left after cutting each finger at its breaks."""
    part = np.zeros(n_rows, dtype=int)
    finger = np.asarray(finger)
    cut = {}
    for row, f, _ in breaks:
        cut.setdefault(f, []).append(row)
    for f, rows_cut in cut.items():
        rows = np.flatnonzero(finger == f)
        for r in rows_cut:
            part[rows[rows >= r]] += 1
    return [np.flatnonzero(part == k) for k in range(part.max() + 1) if np.any(part == k)]


# --- What ``analyze_patch`` returns: ``PatchResult``, its JSON record, and its assembly from the
# method's ``Answer`` (``PatchResult.of``: HK label, warnings, maps).
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

    @classmethod
    def of(cls, ans, prep, method, maps=False, tilted=None):
        """The result of ``ans`` (a ``centre_result.Answer``) for the patch ``prep``
        (``patch_input.Prepared``): the HK label, the warnings (a tilt taken out first),
        the grid maps where ``maps``, the frame moved back to the input's origin."""
        c, L = ans.centre, ans.scale
        # HK label in units of the patch (K of 1/L^2 leaves the float range beyond L ~ 1e+-154)
        k1, k2 = c.k1 * L, c.k2 * L
        iv1, iv2 = (
            None if v is None else tuple(x * L for x in v) for v in (c.k1_interval, c.k2_interval)
        )
        eps = hk_eps(iv1, iv2, k1, k2)
        K, H = k1 * k2, 0.5 * (k1 + k2)
        warnings = [tilted] if tilted else []
        warnings += [f"{prep.dropped} duplicated row(s) counted once"] if prep.dropped else []
        warnings += ans.warnings
        warnings += [f"normals turn {a:.0f} deg at row {r} (finger {f})" for r, f, a in prep.breaks]
        return cls(
            n_points=len(prep.points), method=method, model=ans.model, **vars(c), **vars(ans.stats),
            hk_label=hk_label(K, H, *eps),
            direction1=ans.direction1, order=ans.order, weighting=ans.weighting,
            noise_pos=ans.noise_pos, noise_normal=ans.noise_normal, warnings=warnings,
            discontinuities=prep.breaks,
            maps=grid_maps(*ans.grid, L, c.shape == "plane", eps) if maps else {},
            frame=geometry.PatchFrame(ans.frame.origin + prep.middle, ans.frame.rot), scale=L,
            surface_fn=ans.surface, fit=ans.fit, box=ans.box,
        )  # fmt: skip

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


def grid_maps(channels, gx, gy, scale, plane, hk_eps):
    """Grid maps in input units: k1, k2, H, K, HK labels; S, S regions, C unless a plane.

    ``hk_eps`` (K, H) zero bands in units of the patch (1/L^2, 1/L): labels, S and C come
    from the curvatures in those units, so no square of a curvature leaves the float range;
    ``K`` itself is +-inf where |K| exceeds it (L under ~1e-154)."""
    with np.errstate(over="ignore", invalid="ignore"):
        k1, k2 = eigen(*shape_entries(*channels))
    H, K = 0.5 * (k1 + k2), k1 * k2
    out = {"x": gx * scale, "y": gy * scale, "k1": k1 / scale, "k2": k2 / scale, "H": H / scale}
    with np.errstate(over="ignore", under="ignore"):
        out["K"] = K / scale / scale
    out["hk"] = hk_labels(K, H, hk_eps[0], hk_eps[1])
    if not plane:
        s = shape_index(k1, k2)
        r = curvedness_r(k1, k2)
        safe = np.where(r > 0, r, 1.0) / scale
        out.update(S=s, S_region=s_region_map(s), C=np.where(r > 0, curvedness_c(safe), np.nan))
    return out


def hk_eps(k1_int, k2_int, k1, k2):
    """Zero bands (K, H) for the HK labels from the curvature resolution (0 without intervals)."""
    if k1_int is None:
        return 0.0, 0.0
    h = 0.5 * max(k1_int[1] - k1_int[0], k2_int[1] - k2_int[0])
    return h * max(abs(k1), abs(k2)) + h * h, h
