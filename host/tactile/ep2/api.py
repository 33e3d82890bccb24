"""EP2 in one call: contacts and normals in, shape label with intervals out (ch. 4).

``analyze_patch(points, normals)`` runs the thesis's algorithm (§4.1):
frame the data (§5.1.2), fit a B-spline patch to positions and normal-derived
slopes (§4.6), analyse S, R, C, k1, k2 on an N x N grid (§4.8.1) and label the
shape (§4.8.2) - plus what the thesis leaves as future work: a refit in the
principal frame (§4.10), noise-derived weights (per row type, estimated from
the residuals unless stated), shrinkage of the tensor-product excess toward the
2-jet (``jet_shrink``), propagated-covariance intervals with a model-bias term
(``uncertainty``, ``model_bias``), and discontinuity checks (§6.2.5).

Two shape indices are reported: ``S_mean``/``S_std``, the mean and spread of
S over the grid (the thesis's statistic, §4.8.2), and ``S_patch``, S of the
grid-mean shape operator (entries a, b, c averaged; the anisotropy
debiased, ``uncertainty.anisotropy``; then eigenvalues ``k_patch``): the
noise averages out before the non-linear S, so it is the more accurate
estimate (bench/ep2_peers.py) and the one the label and ``S_interval`` use.

Internally lengths are divided by the patch size L (the larger side of the
contacts' bounding box in the patch frame), so weights and tolerances do not
depend on the unit; curvatures are reported in 1/unit.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import (
    bspline_patch,
    classify,
    discontinuity,
    jet_shrink,
    model_bias,
    patch_frame,
    uncertainty,
)
from tactile.ep2.shape_index import curvedness_c, curvedness_r, hk_labels, s_region_map, shape_index
from tactile.ep2.surface_geometry import eigen, principal, shape_entries
from tactile.errors import DataError, InputError

WEIGHTINGS = ("auto", "tangent", "position")
THESIS_RATIO = 100.0  # favoured : other rows (§4.9)
NOISE_FLOOR = 1e-9  # relative noise floor so exact data keep finite weights
ALIGN_SKIP_DEG = 2.0  # no principal-frame refit when the first pass is this close to aligned
VC_PASSES = 1  # noise re-estimations before the final auto-weighted fit (measured: 1 = 2 = 3)


@dataclass
class PatchResult:
    """Everything ``analyze_patch`` found.  ``to_dict`` gives the JSON record."""

    n_points: int
    shape: str
    confidence: float
    S_mean: float | None
    S_patch: float | None
    k_patch: tuple  # (k1, k2) of the grid-mean shape operator
    S_std: float | None
    R_mean: float
    R_std: float
    C_mean: float | None
    k1_mean: float
    k2_mean: float
    k1_std: float
    k2_std: float
    radius: float | None
    S_interval: tuple | None
    k1_interval: tuple | None
    k2_interval: tuple | None
    radius_interval: tuple | None
    hk_label: str
    direction1: np.ndarray
    degree: int
    weighting: str
    aligned: bool
    cond: float
    votes: dict = field(default_factory=dict)
    discontinuities: list = field(default_factory=list)
    maps: dict = field(default_factory=dict, repr=False)
    hk_eps: tuple = field(default=(0.0, 0.0), repr=False)
    fit: object = field(default=None, repr=False)
    frame: object = field(default=None, repr=False)
    scale: float = 1.0

    def to_dict(self, patch=None):
        keys = (
            "n_points shape confidence S_mean S_patch S_std R_mean R_std C_mean k1_mean k2_mean"
            " k1_std k2_std k_patch radius S_interval k1_interval k2_interval radius_interval"
            " hk_label"
            " direction1 degree weighting aligned cond votes"
        ).split()
        out = {"patch": patch} if patch is not None else {}
        out.update({k: getattr(self, k) for k in keys})
        out["discontinuities"] = [
            {"row": r, "finger": f, "angle_deg": a} for r, f, a in self.discontinuities
        ]
        return out

    def surface(self, xy_patch):
        """Fitted z (patch frame, input units) at patch-frame (x, y) rows."""
        xy = np.asarray(xy_patch, float) / self.scale
        return self.fit.derivatives(xy[:, 0], xy[:, 1])[0] * self.scale

    def surface_world(self, xy_patch):
        """Fitted surface points mapped back to the input (world) frame."""
        xy = np.asarray(xy_patch, float)
        pts = np.column_stack([xy, self.surface(xy)])
        return self.frame.to_world(pts)

    def control_net(self):
        """Control points (nx, ny, 3) of the fitted patch, patch frame, input units (§4.6).

        x and y are the Greville abscissae of the knot vectors, where the
        B-spline's linear precision puts them, so the surface is
        sum P_ij N_i(u) M_j(v) with these points (the meshes of figs. 40, 43, 47).
        """
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
        """(x_min, x_max, y_min, y_max) of the fitted patch, patch frame, input units."""
        d = self.fit.domain
        return tuple(v * self.scale for v in (d.x0, d.x0 + d.hx, d.y0, d.y0 + d.hy))


def analyze_patch(
    points,
    normals,
    *,
    degree=2,
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

    Parameters
    ----------
    points, normals : (n, 3) arrays
        Contact positions and surface normals pointing toward the finger.
    degree : int or (int, int)
        Polynomial degree per direction (2 biquadratic .. 4 biquartic).
    weighting : "auto" | "tangent" | "position"
        "tangent"/"position" favour one row type 100:1 as in §4.9; "auto"
        weights every row by 1/sigma from ``noise_pos`` (length unit) and
        ``noise_normal`` (rad), estimating the ones not given from the
        residuals (per row type, leverage-corrected, ``VC_PASSES`` passes).
    shrink : bool or None
        Shrink the tensor-product excess toward the 2-jet (``jet_shrink``);
        None = on for ``auto`` weighting, off for the thesis's fixed weightings.
    intervals : bool
        Compute the 95 % intervals (``uncertainty.intervals``); without them the
        label's confidence comes from S alone (the covariance, plane test and
        debiasing are kept).
    align : bool
        Refit in the principal frame of a first pass (§4.10).  Off by default:
        measured, it makes S worse for this fit (docs/ep2.md, rotation study).
    finger : sequence or None
        Finger label per row (rows in sweep order) for discontinuity checks.
    maps : bool
        Keep the grid maps (S, C, k1, k2, HK and S-region labels).

    Raises ``InputError`` for malformed arrays and ``DataError`` when the
    contacts do not determine a patch (rank deficient, normals inconsistent).
    """
    pts, nrm = _validate(points, normals, weighting)
    kx, ky = (degree, degree) if np.isscalar(degree) else degree
    seg = (segments, segments) if np.isscalar(segments) else segments
    breaks = discontinuity.find_breaks(nrm, finger, break_angle)
    frame = patch_frame.frame_from_contacts(pts, nrm)
    p = frame.to_patch(pts)
    npat = frame.to_patch_dirs(nrm)
    sx, sy = patch_frame.slopes(npat, max_normal_angle, lines)
    scale = float(max(np.ptp(p[:, 0]), np.ptp(p[:, 1])))
    if not scale > 0:
        raise DataError(
            "all contacts at one point: the patch needs contacts spread in two directions"
        )
    p = p / scale
    grid_xy = _grid_lines(p, grid)
    gx, gy = (g.ravel() for g in np.meshgrid(*grid_xy, indexing="ij"))
    opts = dict(degree=(kx, ky), segments=seg, solver=solver)
    sig = _noise(noise_pos, noise_normal, scale)
    stated = weighting == "auto" and any(v is not None for v in sig)
    fit, sig, design = _fit_weighted(p, sx, sy, weighting, sig, opts)
    rows = fit.grid_rows(*grid_xy, first=1)
    aligned = False
    if align:
        angle = _principal_angle(fit, rows)
        if angle is not None:
            frame = frame.rotated_about_z(angle)
            c, s = np.cos(angle), np.sin(angle)
            p = _turn(p, c, s)
            sx, sy = c * sx + s * sy, -s * sx + c * sy
            gx, gy = c * gx + s * gy, -s * gx + c * gy
            fit, _, design = _fit_weighted(p, sx, sy, weighting, sig, opts)
            rows = fit.rows(gx, gy, first=1)
            aligned = True
    s2 = uncertainty.residual_scale(fit.chi2, fit.dof, stated)
    if (weighting == "auto" if shrink is None else shrink) and s2 is not None:
        fit, _, _ = jet_shrink.shrink(fit, p[:, 2], sx, sy, s2, design)
    centre_xy = np.array([gx.mean(), gy.mean()])
    result = _analyse(fit, rows, scale, s2, intervals, (p[:, :2], centre_xy))
    centre = [v.mean() for v in _split(rows @ fit.coef, rows.shape[0] // 5)]
    result.update(
        n_points=len(pts),
        degree=kx,
        weighting=weighting,
        aligned=aligned,
        cond=fit.cond,
        discontinuities=breaks,
        fit=fit,
        frame=frame,
        scale=scale,
        direction1=frame.to_world_dirs(principal(*centre)["dir1"]),
    )
    if maps:
        result["maps"] = _maps(fit, rows, gx, gy, scale, result)
    return PatchResult(**result)


def _validate(points, normals, weighting):
    if weighting not in WEIGHTINGS:
        raise InputError(f"unknown weighting {weighting!r} (choose {', '.join(WEIGHTINGS)})")
    pts = np.asarray(points, float)
    nrm = np.asarray(normals, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or nrm.shape != pts.shape:
        raise InputError(f"points and normals must both be (n, 3); got {pts.shape} and {nrm.shape}")
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(nrm))):
        raise InputError("points and normals must be finite numbers")
    return pts, patch_frame.unit_normals(nrm)


def _grid_lines(p, n):
    """x and y lines of the N x N grid over the contacts' bounding box (patch frame, §4.8.1)."""
    xs = np.linspace(p[:, 0].min(), p[:, 0].max(), n)
    ys = np.linspace(p[:, 1].min(), p[:, 1].max(), n)
    return xs, ys


def _grid(p, n):
    """The N x N grid points (x, y), x index slowest."""
    gx, gy = np.meshgrid(*_grid_lines(p, n), indexing="ij")
    return gx.ravel(), gy.ravel()


def _turn(p, c, s):
    q = p.copy()
    q[:, 0] = c * p[:, 0] + s * p[:, 1]
    q[:, 1] = -s * p[:, 0] + c * p[:, 1]
    return q


def _noise(noise_pos, noise_normal, scale):
    """Stated (sigma_pos / L, sigma_normal), None for a component not stated."""
    sp = None if noise_pos is None else max(float(noise_pos) / scale, NOISE_FLOOR)
    sn = None if noise_normal is None else max(float(noise_normal), NOISE_FLOOR)
    return sp, sn


def _fit_weighted(p, sx, sy, weighting, sig, opts):
    """Fit with the chosen weights; ``auto`` estimates the unstated noise (``VC_PASSES``)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    domain, rows = bspline_patch.prepare(x, y, opts["degree"], opts["segments"])
    kw = dict(opts, domain=domain, rows=rows)
    if weighting in ("tangent", "position"):
        w_pos, w_s = (1.0, THESIS_RATIO) if weighting == "tangent" else (THESIS_RATIO, 1.0)
        return bspline_patch.fit(x, y, z, sx, sy, w_pos, w_s, w_s, **kw), sig, rows
    g2 = sx * sx + sy * sy
    stated = sig
    sp, sn = (1.0 if s is None else s for s in sig)  # unstated: start at 1:1
    passes = 0 if None not in stated else VC_PASSES
    for i in range(passes + 1):
        w_pos = 1.0 / (sp * np.sqrt(1.0 + g2))
        w_s = 1.0 / (sn * (1.0 + g2))
        fit = bspline_patch.fit(x, y, z, sx, sy, w_pos, w_s, w_s, **kw)
        if i < passes:
            fp, fs = _variance_factors(fit, w_pos, w_s)
            sp = sp if stated[0] is not None else max(sp * np.sqrt(fp), NOISE_FLOOR)
            sn = sn if stated[1] is not None else max(sn * np.sqrt(fs), NOISE_FLOOR)
    return fit, (sp, sn), rows


def _variance_factors(fit, w_pos, w_s):
    """Per row type (position, slope): weighted RSS over its residual degrees of freedom
    (rows minus the leverage they take, as in REML), 1 when a type has no spare rows."""
    rz, rx, ry = fit.residuals
    n = rz.size
    lev = fit.leverage
    out = []
    for r2, rows, used in (
        (np.sum(np.square(rz * w_pos)), n, lev[:n].sum()),
        (np.sum(np.square(rx * w_s)) + np.sum(np.square(ry * w_s)), 2 * n, lev[n:].sum()),
    ):
        spare = rows - used
        out.append(r2 / spare if spare >= 1.0 and r2 > 0 else 1.0)
    return out


def _split(values, n):
    return [values[i * n : (i + 1) * n] for i in range(5)]


def _principal_angle(fit, rows):
    """Mean k1 direction in the xy plane (doubled-angle average weighted by k1 - k2).

    None when the patch is isotropic or already within ``ALIGN_SKIP_DEG`` of
    its principal frame, so the refit would change nothing.
    """
    zx, zy, zxx, zxy, zyy = _split(rows @ fit.coef, rows.shape[0] // 5)
    geo = principal(zx, zy, zxx, zxy, zyy)
    d = geo["dir1"]
    w = geo["k1"] - geo["k2"]
    vec = np.sum(w * np.exp(2j * np.arctan2(d[:, 1], d[:, 0])))
    if not abs(vec) > 1e-9 * max(float(np.sum(w)), 1e-300):
        return None
    angle = 0.5 * float(np.angle(vec))
    off = abs(np.degrees(angle)) % 90.0
    return None if min(off, 90.0 - off) < ALIGN_SKIP_DEG else angle


def _analyse(fit, rows, scale, s2, intervals=True, contacts=None):
    """Grid statistics, patch curvature, intervals and label (§4.8); lengths still / ``scale``.

    ``s2`` is the variance factor of the fit (None: no covariance, so no plane
    test, no debiasing and no intervals; the label then comes from S alone).
    ``contacts`` = (xy, centre) adds the model-bias term (``model_bias``) to the intervals.
    """
    n = rows.shape[0] // 5
    channels = _split(rows @ fit.coef, n)
    a, b, c = shape_entries(*channels)
    k1, k2 = eigen(a, b, c)
    k1m, k2m = float(k1.mean()), float(k2.mean())
    r = curvedness_r(k1, k2)
    r_mean = float(r.mean())
    keys = "S_mean S_patch S_std C_mean radius S_interval radius_interval k1_interval k2_interval"
    out = dict.fromkeys(keys.split())
    out["votes"] = {}
    tensor, cov, d2, iv = np.array([a.mean(), b.mean(), c.mean()]), None, None, None
    if s2 is not None:
        tensor, G = uncertainty.tensor_and_jacobian(channels, rows)
        cov = uncertainty.tensor_cov(G, fit.cov_factor, s2)
        d2 = classify.flatness_distance(tensor, cov)
    m, h, lam = uncertainty.anisotropy(tensor, np.zeros((3, 3)) if cov is None else cov)
    if cov is not None and intervals:
        bias = None
        if contacts is not None and fit.data_map is not None:
            bias = model_bias.bias(fit, *contacts, tensor, lambda c: _grid_tensor(rows, c))
        iv = uncertainty.intervals(tensor, cov, m, h, lam, bias)
        out["k1_interval"] = (iv["k1"][0] / scale, iv["k1"][1] / scale)
        out["k2_interval"] = (iv["k2"][0] / scale, iv["k2"][1] / scale)
    if classify.is_plane(r_mean, d2):
        out.update(shape="plane", confidence=classify.plane_confidence(r_mean, d2))
    else:
        s_patch = float(shape_index(m + h, m - h))
        s_sd = None
        if iv is not None:
            out["S_interval"] = iv["S"]
            root = np.sqrt(iv["crit"])
            s_sd = ((s_patch - iv["S"][0]) / root, (iv["S"][1] - s_patch) / root)
            lo, hi = iv["kmax"]
            out["radius_interval"] = (
                scale / hi if hi > 0 else None,
                scale / lo if lo > 0 else None,
            )
        p_flat = 0.0 if d2 is None else classify.plane_confidence(r_mean, d2)
        out["shape"], out["confidence"], out["votes"] = classify.vote(s_patch, s_sd, p_flat)
        s = shape_index(k1, k2)
        pos = r > 0
        out.update(
            S_patch=s_patch,
            S_mean=float(s.mean()),
            S_std=float(s.std()),
            C_mean=float(curvedness_c(r[pos] / scale).mean()) if pos.any() else None,
            radius=scale / max(abs(k1m), abs(k2m)),
        )
    out["k_patch"] = ((m + h) / scale, (m - h) / scale)
    eps_h, eps_k = _hk_eps(out["k1_interval"], out["k2_interval"], k1m / scale, k2m / scale)
    H, K = 0.5 * (k1 + k2) / scale, k1 * k2 / scale**2
    out.update(
        R_mean=r_mean / scale,
        R_std=float(r.std()) / scale,
        k1_mean=k1m / scale,
        k2_mean=k2m / scale,
        k1_std=float(k1.std()) / scale,
        k2_std=float(k2.std()) / scale,
        hk_label=str(hk_labels(np.array([K.mean()]), np.array([H.mean()]), eps_k, eps_h)[0]),
        hk_eps=(eps_k, eps_h),
    )
    return out


def _grid_tensor(rows, coef):
    """Grid-mean shape-operator entries (a, b, c) of a coefficient vector."""
    a, b, c = shape_entries(*_split(rows @ coef, rows.shape[0] // 5))
    return np.array([a.mean(), b.mean(), c.mean()])


def _hk_eps(k1_int, k2_int, k1m, k2m):
    """Zero bands (H, K) for the HK labels: the curvature resolution h and its
    propagation to K = k1 k2 (|k| h + h^2), or exact zero without intervals."""
    if k1_int is None:
        return 0.0, 0.0
    h = 0.5 * max(k1_int[1] - k1_int[0], k2_int[1] - k2_int[0])
    return h, h * max(abs(k1m), abs(k2m)) + h * h


def _maps(fit, rows, gx, gy, scale, result):
    """Grid maps in input units: k1, k2, H, K, HK labels; S, S regions, C unless a plane."""
    n = rows.shape[0] // 5
    k1, k2 = eigen(*shape_entries(*_split(rows @ fit.coef, n)))
    k1, k2 = k1 / scale, k2 / scale
    H, K = 0.5 * (k1 + k2), k1 * k2
    eps_k, eps_h = result["hk_eps"]
    out = {
        "x": gx * scale,
        "y": gy * scale,
        "k1": k1,
        "k2": k2,
        "H": H,
        "K": K,
        "hk": hk_labels(K, H, eps_k, eps_h),
    }
    if result["shape"] != "plane":
        s = shape_index(k1, k2)
        r = curvedness_r(k1, k2)
        out.update(
            S=s,
            S_region=s_region_map(s),
            C=np.where(r > 0, curvedness_c(np.where(r > 0, r, 1.0)), np.nan),
        )
    return out


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
