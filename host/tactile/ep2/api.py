"""EP2 in one call: contacts and normals in, curvature at the patch centre with a label out.

``analyze_patch(points, normals)`` runs the thesis's algorithm (§4.1) with the
default estimator ``method="jet"`` (``local_jet``, ``jet_answers``): jets of
positions and normals about the patch centre, the 2-jet moved toward the 3-jet on
evidence, bad contacts left out by name, curvature reported AT THE CENTRE with
95 % intervals that count the model's truncation, refused (``DataError``) where
the data do not determine it or where positions and normals disagree.
``method="spline"`` is the thesis's B-spline patch (``spline_analysis``), kept to
reproduce chapters 4-5.

One definition everywhere (table, JSON, plots): ``S``, ``k1``, ``k2``,
``radius`` and ``C`` are at the patch centre (the middle of the contacts'
bounding box in the patch frame); ``S_mean``, ``S_std``, ``R_mean``,
``C_mean``, ``k1_mean`` ... are the thesis's statistics over the N x N grid
(§4.8.2).  Lengths are in the input unit, curvatures in 1/unit.

The steps: ``patch_input`` (validation, duplicates, centring), ``local_jet`` (the fit),
``jet_answers`` (refusals, positions against normals, intervals, labels), and here the
``PatchResult`` (its JSON record, and its assembly from the method's fields).
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import (
    centre_result,
    edges,
    jet_answers,
    local_jet,
    patch_frame,
    patch_input,
    tilt,
)
from tactile.ep2.centre_result import hk_eps
from tactile.ep2.geometry import hk_labels
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
    kw = patch_input.keywords(method, jet, spline, maps, **options)
    prep = patch_input.prepare(points, normals, finger, lines, kw)
    edges.check(prep)
    prep, tilted = tilt.untilt(prep)
    pts, nrm, opts = prep.points, prep.normals, prep.opts
    if method == "spline":
        from tactile.ep2 import spline_analysis  # (start-up: scipy only for the spline)

        out = spline_analysis.analyze(pts, nrm, opts)
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
    nrm = patch_frame.unit_normals(np.asarray(normals, float))
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
        frame=patch_frame.PatchFrame(out["frame"].origin + middle, out["frame"].rot),
        scale=L,
        surface_fn=out["surface"],
        fit=out.get("fit"),
        box=box,
    )
