"""The thesis's method's analysis of one patch (``method="spline"``, ``analyze``): the
B-spline of ``spline`` fitted with the thesis's weights or by maximum likelihood, its
curvature at the patch centre with intervals and a label, and the grid statistics.

Frame and units as the default's; weights are the thesis's fixed ratios or, for ``auto``,
per-row-type noise (REML, ``VC_PASSES`` passes); ``spline.shrink_to_jet`` shrinks the
tensor-product excess toward the 2-jet; ``model_bias`` adds the biquadratic's bias on
round surfaces to the intervals.  The headline curvature is the spline's at the patch
centre, as for the default (``centre_result.summary``); the grid statistics (S_mean ...)
are the thesis's (§4.8.2).

- **Covariance.**  t is a smooth function of the coefficients, so Cov(t) = s^2 (G F)(G
  F)^T with G = dt/dcoef (``tensor_and_jacobian``: a complex-step derivative along the
  five derivative channels, exact to round-off) and F the coefficients' covariance factor.
- **Model bias** (``model_bias``, beyond the thesis): the refit of the constant-curvature
  surface, added to the covariance of the intervals.
"""

import numpy as np

from tactile.ep2 import centre_result, geometry
from tactile.ep2.centre_result import Answer
from tactile.ep2.geometry import principal, shape_entries
from tactile.ep2.spline import fit_patch, prepare, shrink_to_jet
from tactile.errors import DataError

THESIS_RATIO = 100.0  # favoured : other rows (§4.9)
NOISE_FLOOR = 1e-9  # relative noise floor so exact data keep finite weights
ALIGN_SKIP_DEG = 2.0  # no principal-frame refit when the first pass is this close to aligned
VC_PASSES = 1  # noise re-estimations before the final auto-weighted fit (measured: 1 = 2 = 3)


def analyze(prep, opts):
    """The ``Answer`` of one prepared patch (``patch_input.Prepared``: its ``jet`` options
    read too) with the spline's options ``opts`` (``SplineOptions``)."""
    pts, nrm, jet = prep.points, prep.normals, prep.jet
    order = 2 if opts.order is None else opts.order
    kx, ky = (order,) * 2 if np.isscalar(order) else order
    seg = (opts.segments,) * 2 if np.isscalar(opts.segments) else opts.segments
    weighting = opts.weighting
    frame = geometry.frame_from_contacts(pts, nrm)
    p = frame.to_patch(pts)
    sx, sy = geometry.slopes(frame.to_patch_dirs(nrm), jet.max_normal_angle, prep.lines)
    scale = float(max(np.ptp(p[:, 0]), np.ptp(p[:, 1])))
    if not scale > 0:
        raise DataError(
            "all contacts at one point: the patch needs contacts spread in two directions"
        )
    p = p / scale
    grid_xy = _grid_lines(p, jet.grid)
    fit_opts = ((kx, ky), seg, opts.solver)
    sig = _noise(jet.noise_pos, jet.noise_normal, scale)
    stated = weighting == "auto" and any(v is not None for v in sig)
    fit, sig, design = _fit_weighted(p, sx, sy, weighting, sig, *fit_opts)
    if opts.align:
        angle = _principal_angle(fit, fit.grid_rows(*grid_xy, first=1))
        if angle is not None:
            frame = frame.rotated_about_z(angle)
            c, s = np.cos(angle), np.sin(angle)
            p = _turn(p, c, s)
            sx, sy = c * sx + s * sy, -s * sx + c * sy
            grid_xy = _grid_lines(p, jet.grid)
            fit, _, design = _fit_weighted(p, sx, sy, weighting, sig, *fit_opts)
    s2 = residual_scale(fit.chi2, fit.dof, stated)
    if (weighting == "auto" if opts.shrink is None else opts.shrink) and s2 is not None:
        fit, _, _ = shrink_to_jet(fit, p[:, 2], sx, sy, s2, design)
    centre, d1 = _centre(fit, p, grid_xy, scale, s2, jet.intervals)
    channels = np.split(fit.grid_rows(*grid_xy, first=1) @ fit.coef, 5)
    ch = [np.asarray(c)[None] for c in channels]  # (a stack of one)
    (stats,) = geometry.grid_stats(ch, np.array([scale]), [centre.shape == "plane"])
    gx, gy = (g.ravel() for g in np.meshgrid(*grid_xy, indexing="ij"))
    d = fit.domain
    return Answer(
        centre, stats,
        f"B-spline degree {kx}x{ky}, {seg[0]}x{seg[1]} segment(s), {weighting} weights",
        kx, weighting, None if sig[0] is None else sig[0] * scale, sig[1], frame, scale,
        lambda xy: fit.derivatives(xy[:, 0], xy[:, 1])[0], (channels, gx, gy),
        frame.to_world_dirs(d1), (d.x0, d.x0 + d.hx, d.y0, d.y0 + d.hy), [], fit,
    )  # fmt: skip


def _centre(fit, p, grid_xy, scale, s2, intervals):
    """(``Centre``, first principal direction in the frame) at the middle of the contacts'
    box: tensor, covariance, model bias, label."""
    centre = np.array([0.5 * (g[0] + g[-1]) for g in grid_xy])
    rows = fit.rows(centre[:1], centre[1:], first=1)
    channels = [np.atleast_1d(v) for v in np.split(rows @ fit.coef, 5)]
    if s2 is None:  # no spare rows: no covariance, the label from S alone
        t = np.array([float(v[0]) for v in shape_entries(*channels)])
        one = (t[None], np.zeros((1, 3, 3)), np.zeros((1, 3)), np.array([scale]), False)
        (out,) = centre_result.summary(*one)
    else:
        t, G = tensor_and_jacobian(channels, rows)
        cov = tensor_cov(G, fit.cov_factor, s2)
        bias = np.zeros(3)
        if intervals and fit.data_map is not None:
            bias = model_bias(fit, p[:, :2], centre, t, lambda c: _tensor(rows, c))
        one = (t[None], cov[None], bias[None], np.array([scale]), intervals)
        (out,) = centre_result.summary(*one, plane_holds_zero=True)
    d = principal(*(v[0] for v in channels))["dir1"]
    return out, np.asarray(d, float)


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


def _fit_weighted(p, sx, sy, weighting, sig, degree, segments, solver):
    """Fit with the chosen weights; ``auto`` estimates the unstated noise (``VC_PASSES``)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    domain, rows = prepare(x, y, degree, segments)
    kw = dict(degree=degree, segments=segments, solver=solver, domain=domain, rows=rows)
    if weighting in ("tangent", "position"):
        w_pos, w_s = (1.0, THESIS_RATIO) if weighting == "tangent" else (THESIS_RATIO, 1.0)
        return fit_patch(x, y, z, sx, sy, w_pos, w_s, w_s, **kw), (None, None), rows
    g2 = sx * sx + sy * sy
    stated = sig
    sp, sn = (1.0 if s is None else s for s in sig)  # unstated: start at 1:1
    passes = 0 if None not in stated else VC_PASSES
    for i in range(passes + 1):
        w_pos = 1.0 / (sp * np.sqrt(1.0 + g2))
        w_s = 1.0 / (sn * (1.0 + g2))
        fit = fit_patch(x, y, z, sx, sy, w_pos, w_s, w_s, **kw)
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


def residual_scale(chi2, dof, noise_stated):
    """Variance factor s^2 for the covariance; None when the fit has no spare rows."""
    if dof <= 0:
        return 1.0 if noise_stated else None
    s2 = chi2 / dof
    return max(s2, 1.0) if noise_stated else s2


def tensor_and_jacobian(channels, rows):
    """Grid-mean entries t (3,) and dt/dcoef (3, p).

    ``channels`` = (zx, zy, zxx, zxy, zyy) at the grid points (each (n,));
    ``rows`` the matching design rows stacked (5 n, p).
    """
    n = channels[0].size
    step = 1e-20
    ch = np.broadcast_to(np.asarray(channels, float), (5, 5, n)).astype(complex)
    ch[np.arange(5), np.arange(5)] += 1j * step  # perturb channel k in copy k
    a, b, c = shape_entries(*np.moveaxis(ch, 1, 0))  # each (5 copies, n)
    t = np.array([a[0].real.mean(), b[0].real.mean(), c[0].real.mean()])
    J = np.stack([a.imag, b.imag, c.imag]) / step  # (3, 5, n)
    G = np.einsum("ikn,knp->ip", J, rows.reshape(5, n, -1))
    return t, G / n


def tensor_cov(G, cov_factor, s2):
    GF = G @ cov_factor
    return s2 * (GF @ GF.T)


# --- Model bias of the patch curvature: refit of the constant-curvature surface.
#
# A biquadratic cannot follow a circle: on a cylinder of radius 8 over a 4 x 4
# patch its grid-mean curvature is ~1 % low, which at low noise is several
# standard deviations, so intervals from the noise alone miss the truth
# (docs/ep2_thesis.md, item 9).  The bias is estimated by fitting, with the same
# rows, weights and shrinkage (``SplineFit.data_map``, a linear map), noise-free
# data from the surface whose shape operator is the estimated one everywhere.
# To fourth order about the patch centre c, with A = -P (P the estimated
# shape-operator matrix, d = x - c):
#
#     z = (d^T A d)/2 + (d^T A d)(d^T A^2 d)/8
#
# (exact to that order for spheres and cylinders: z = -k r^2/2 - k^3 r^4/8).
# The bias vector is the refit's grid-mean entries minus P's; ``api`` adds its
# outer product to the covariance of the intervals (not to the estimate: for a
# quadric height field the fit itself is unbiased and the term only widens).


def constant_curvature_data(xy, centre, tensor):
    """(z, slope-x, slope-y) of the constant-shape-operator surface at points ``xy`` (n, 2)."""
    a, b, c = tensor
    A = -np.array([[a, b], [b, c]])
    d = np.asarray(xy, float) - centre
    ad = d @ A
    a2d = ad @ A
    q1 = np.einsum("ij,ij->i", d, ad)
    q2 = np.einsum("ij,ij->i", ad, ad)  # d^T A^2 d
    z = 0.5 * q1 + q1 * q2 / 8.0
    grad = ad + (ad * q2[:, None] + a2d * q1[:, None]) / 4.0
    return z, grad[:, 0], grad[:, 1]


def model_bias(fit, xy, centre, tensor, grid_tensor):
    """Bias (3,) of the grid-mean entries: refit of ``constant_curvature_data`` minus ``tensor``.

    ``grid_tensor(coef)`` returns the grid-mean entries of a coefficient vector.
    """
    z, gx, gy = constant_curvature_data(xy, centre, tensor)
    coef = fit.data_map @ np.concatenate([z, gx, gy])
    return grid_tensor(coef) - np.asarray(tensor, float)
