"""The thesis's method (``method="spline"``): a tensor-product B-spline patch (§4.6).

Kept to reproduce chapters 4-5 (``--order 3 --weighting tangent`` is the
thesis's bicubic at 100:1, §4.9), not the default: on the held-out grid the
centre jet (``local_jet``) is more accurate.  Frame and units as there; the
fit is ``spline``; weights are the thesis's fixed ratios or, for
``auto``, per-row-type noise (REML, ``VC_PASSES`` passes); ``shrink_to_jet``
shrinks the tensor-product excess toward the 2-jet; ``uncertainty.model_bias`` adds the
biquadratic's bias on round surfaces to the intervals.  The headline
curvature is the spline's at the patch centre, as for the default; the grid
statistics (S_mean ...) are the thesis's (§4.8.2).
"""

import dataclasses
from functools import lru_cache

import numpy as np

from tactile.ep2 import centre_result, patch_frame, spline, uncertainty
from tactile.ep2.geometry import principal, shape_entries
from tactile.errors import DataError

WEIGHTINGS = ("auto", "tangent", "position")
THESIS_RATIO = 100.0  # favoured : other rows (§4.9)
NOISE_FLOOR = 1e-9  # relative noise floor so exact data keep finite weights
ALIGN_SKIP_DEG = 2.0  # no principal-frame refit when the first pass is this close to aligned
VC_PASSES = 1  # noise re-estimations before the final auto-weighted fit (measured: 1 = 2 = 3)


def analyze(pts, nrm, opts):
    """Result fields (dict) of one patch; ``opts`` are ``analyze_patch``'s keywords."""
    kx, ky = (opts["order"],) * 2 if np.isscalar(opts["order"]) else opts["order"]
    seg = opts["segments"]
    seg = (seg, seg) if np.isscalar(seg) else seg
    weighting = opts["weighting"]
    frame = patch_frame.frame_from_contacts(pts, nrm)
    p = frame.to_patch(pts)
    sx, sy = patch_frame.slopes(frame.to_patch_dirs(nrm), opts["max_normal_angle"], opts["lines"])
    scale = float(max(np.ptp(p[:, 0]), np.ptp(p[:, 1])))
    if not scale > 0:
        raise DataError(
            "all contacts at one point: the patch needs contacts spread in two directions"
        )
    p = p / scale
    grid_xy = _grid_lines(p, opts["grid"])
    fit_opts = dict(degree=(kx, ky), segments=seg, solver=opts["solver"])
    sig = _noise(opts["noise_pos"], opts["noise_normal"], scale)
    stated = weighting == "auto" and any(v is not None for v in sig)
    fit, sig, design = _fit_weighted(p, sx, sy, weighting, sig, fit_opts)
    aligned = False
    if opts["align"]:
        angle = _principal_angle(fit, fit.grid_rows(*grid_xy, first=1))
        if angle is not None:
            frame = frame.rotated_about_z(angle)
            c, s = np.cos(angle), np.sin(angle)
            p = _turn(p, c, s)
            sx, sy = c * sx + s * sy, -s * sx + c * sy
            grid_xy = _grid_lines(p, opts["grid"])
            fit, _, design = _fit_weighted(p, sx, sy, weighting, sig, fit_opts)
            aligned = True
    s2 = uncertainty.residual_scale(fit.chi2, fit.dof, stated)
    shrink = opts["shrink"]
    if (weighting == "auto" if shrink is None else shrink) and s2 is not None:
        fit, _, _ = shrink_to_jet(fit, p[:, 2], sx, sy, s2, design)
    out = _centre(fit, p, grid_xy, scale, s2, opts["intervals"])
    out.update(
        order=kx,
        weighting=weighting,
        aligned=aligned,
        model=f"B-spline degree {kx}x{ky}, {seg[0]}x{seg[1]} segment(s), {weighting} weights",
        noise_pos=None if sig[0] is None else sig[0] * scale,
        noise_normal=sig[1],
        fit=fit,
        frame=frame,
        scale=scale,
        surface=lambda xy: fit.derivatives(xy[:, 0], xy[:, 1])[0],
    )
    rows = fit.grid_rows(*grid_xy, first=1)
    channels = np.split(rows @ fit.coef, 5)
    stats = centre_result.grid_statistics(channels, scale, out["shape"] == "plane")
    out.update(stats)
    gx, gy = (g.ravel() for g in np.meshgrid(*grid_xy, indexing="ij"))
    out["grid"] = (channels, gx, gy)
    return out


def _centre(fit, p, grid_xy, scale, s2, intervals):
    """Headline at the centre of the contacts' box: tensor, covariance, model bias, label."""
    centre = np.array([0.5 * (g[0] + g[-1]) for g in grid_xy])
    rows = fit.rows(centre[:1], centre[1:], first=1)
    channels = [np.atleast_1d(v) for v in np.split(rows @ fit.coef, 5)]
    if s2 is None:  # no spare rows: no covariance, the label from S alone
        t = np.array([float(v[0]) for v in shape_entries(*channels)])
        one = (t[None], np.zeros((1, 3, 3)), np.zeros((1, 3)), np.array([scale]), False)
        (out,) = centre_result.summary(*one)
    else:
        t, G = uncertainty.tensor_and_jacobian(channels, rows)
        cov = uncertainty.tensor_cov(G, fit.cov_factor, s2)
        bias = np.zeros(3)
        if intervals and fit.data_map is not None:
            bias = uncertainty.model_bias(fit, p[:, :2], centre, t, lambda c: _tensor(rows, c))
        one = (t[None], cov[None], bias[None], np.array([scale]), intervals)
        (out,) = centre_result.summary(*one, plane_holds_zero=True)
    d = principal(*(v[0] for v in channels))["dir1"]
    out["direction1_patch"] = np.asarray(d, float)
    out["centre"] = centre
    return out


def _tensor(rows, coef):
    a, b, c = shape_entries(*np.split(rows @ coef, 5))
    return np.array([a.mean(), b.mean(), c.mean()])


def _grid_lines(p, n):
    """x and y lines of the N x N grid over the contacts' bounding box (patch frame, §4.8.1)."""
    xs = np.linspace(p[:, 0].min(), p[:, 0].max(), n)
    ys = np.linspace(p[:, 1].min(), p[:, 1].max(), n)
    return xs, ys


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
    domain, rows = spline.prepare(x, y, opts["degree"], opts["segments"])
    kw = dict(opts, domain=domain, rows=rows)
    if weighting in ("tangent", "position"):
        w_pos, w_s = (1.0, THESIS_RATIO) if weighting == "tangent" else (THESIS_RATIO, 1.0)
        return spline.fit(x, y, z, sx, sy, w_pos, w_s, w_s, **kw), (None, None), rows
    g2 = sx * sx + sy * sy
    stated = sig
    sp, sn = (1.0 if s is None else s for s in sig)  # unstated: start at 1:1
    passes = 0 if None not in stated else VC_PASSES
    for i in range(passes + 1):
        w_pos = 1.0 / (sp * np.sqrt(1.0 + g2))
        w_s = 1.0 / (sn * (1.0 + g2))
        fit = spline.fit(x, y, z, sx, sy, w_pos, w_s, w_s, **kw)
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


def _principal_angle(fit, rows):
    """Mean k1 direction in the xy plane (doubled-angle average weighted by k1 - k2).

    None when the patch is isotropic or already within ``ALIGN_SKIP_DEG`` of
    its principal frame, so the refit would change nothing.
    """
    zx, zy, zxx, zxy, zyy = np.split(rows @ fit.coef, 5)
    geo = principal(zx, zy, zxx, zxy, zyy)
    d = geo["dir1"]
    w = geo["k1"] - geo["k2"]
    vec = np.sum(w * np.exp(2j * np.arctan2(d[:, 1], d[:, 0])))
    if not abs(vec) > 1e-9 * max(float(np.sum(w)), 1e-300):
        return None
    angle = 0.5 * float(np.angle(vec))
    off = abs(np.degrees(angle)) % 90.0
    return None if min(off, 90.0 - off) < ALIGN_SKIP_DEG else angle


# --- Empirical-Bayes shrinkage of a tensor-product patch toward its 2-jet (beyond the thesis).
#
# A degree (kx, ky) patch spans the monomials u^i v^j, i <= kx, j <= ky. Only the six of total
# degree <= 2 (the quadric, or 2-jet) are needed for a surface of constant curvature to second
# order; the others (u^2 v, u v^2, u^2 v^2, ... the *excess*) carry the fourth-order shape but,
# with 36 noisy contacts on three finger lines, mostly fit noise. The excess is shrunk toward zero
# by the positive-part empirical-Bayes factor (James-Stein type, g-prior with its scale estimated
# by the method of moments)
#
# w = max(0, 1 - q / d^2), d^2 = (chi^2_jet - chi^2_full) / s^2,
#
# q the number of excess terms, d^2 the Wald statistic of the excess (chi^2_q when the excess is
# zero) and s^2 the fit's variance factor. The result is c = c_jet + w (c_full - c_jet), with
# c_jet the least-squares fit constrained to the 2-jet span. Clean data (d^2 >> q) keep the full
# patch (w -> 1); noisy data approach the quadric.
#
# Everything uses the full fit's precision factor R = F^-1 (R^T R = A^T A, F the covariance
# factor), so the weighted rows are not revisited. With w held fixed, nested least squares give
# Cov(c_jet, c_full) = Cov(c_jet), hence Cov(c) = (1 - w^2) Cov(c_jet) + w^2 Cov(c_full).


@lru_cache(maxsize=64)
def jet_span(kx, ky, tx, ty):
    """(p, 6) spline coefficients of 1, u, v, u^2, u v, v^2 on the unit square.

    Exact: every polynomial of degree <= k per direction lies in the spline
    space, so interpolation on a fine enough tensor grid recovers it.
    """
    nx, ny = len(tx) - kx - 1, len(ty) - ky - 1
    u = np.linspace(0.0, 1.0, nx + 2)
    v = np.linspace(0.0, 1.0, ny + 2)
    uu, vv = (g.ravel() for g in np.meshgrid(u, v, indexing="ij"))
    rows = spline.rowwise_kron(spline.basis(uu, kx, tx), spline.basis(vv, ky, ty))
    mono = np.column_stack([np.ones_like(uu), uu, vv, uu * uu, uu * vv, vv * vv])
    return np.linalg.lstsq(rows, mono, rcond=None)[0]


def shrink_to_jet(fit, z, sx, sy, s2, rows):
    """Shrink ``fit`` (a ``SplineFit``) toward its 2-jet.  Returns (fit, w, d2).

    ``z, sx, sy`` are the data the fit was made from and ``rows`` its
    unweighted design rows (``spline.prepare``), for the residuals;
    ``s2`` the variance factor of the weighted rows (chi^2/dof, or 1 with the
    noise stated).  Patches with no excess (degree < 2, or exactly a 2-jet)
    come back unchanged with w = 1.
    """
    kx, ky = fit.degree
    p = fit.coef.size
    q = p - 6
    if min(kx, ky) < 2 or q <= 0:
        return fit, 1.0, np.inf
    Q = jet_span(kx, ky, fit.tx, fit.ty)
    R = np.linalg.inv(fit.cov_factor)
    U, s, Vt = np.linalg.svd(R @ Q, full_matrices=False)
    beta = Vt.T @ ((U.T @ (R @ fit.coef)) / s)
    c_jet = Q @ beta
    delta = float(np.sum(np.square(R @ (c_jet - fit.coef))))  # chi^2_jet - chi^2_full
    if not delta > 0:
        return fit, 1.0, np.inf
    d2 = delta / s2 if s2 > 0 else np.inf
    w = max(0.0, 1.0 - q / d2)
    coef = c_jet + w * (fit.coef - c_jet)
    f_jet = Q @ (Vt.T / s)
    # the same shrinkage as a linear map of the full coefficients: c = ((1 - w) P + w I) c_full
    proj = f_jet @ (U.T @ R)
    shrink_map = (1.0 - w) * proj + w * np.eye(p)
    factor = np.hstack([np.sqrt(1.0 - w * w) * f_jet, w * fit.cov_factor])
    a0, a1, a2 = rows
    res = (z - a0 @ coef, sx - a1 @ coef, sy - a2 @ coef)
    chi2 = fit.chi2 + (1.0 - w) ** 2 * delta
    data_map = None if fit.data_map is None else shrink_map @ fit.data_map
    out = dataclasses.replace(
        fit, coef=coef, cov_factor=factor, chi2=chi2, residuals=res, data_map=data_map
    )
    return out, w, d2
