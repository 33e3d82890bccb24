"""Patch-level curvature, its covariance, and 95 % intervals for S, k1, k2 and |k|max.

The patch is summarised by the grid mean t = (a, b, c) of the symmetric
shape-operator entries (``geometry.shape_entries``): m = (a + c)/2 is
the mean curvature, v = ((a - c)/2, b) the anisotropy, h = |v|, and
k1,2 = m +/- h, S = (2/pi) atan2(m, h) (§2.4).

- **Covariance.**  t is a smooth function of the spline coefficients, so
  Cov(t) = s^2 (G F)(G F)^T with G = dt/dcoef (complex-step derivative along
  the five derivative channels, exact to round-off) and F the coefficients'
  covariance factor.  No Monte Carlo.
- **Debiased anisotropy.**  E|v_hat|^2 = |v|^2 + tr Cov(v), so the plug-in h is
  biased up: a noisy sphere always looks anisotropic (S < 1, k2 < k1).  The
  estimate uses h^2 = max(|v_hat|^2 - tr Cov(v), 0) (the Rician bias correction);
  it cuts the sphere's RMS S error by ~40 % (measured by a peers bench since removed).
- **Intervals** by projecting the confidence ellipsoid
  {t : (t - t_hat)^T Cov^-1 (t - t_hat) <= c} onto each quantity (its range over
  the ellipsoid, boundary sampled plus the points where the umbilic axis
  h = 0 pierces it).  For a smooth quantity and c = chi^2_1(95 %) = 3.84 this is
  the delta-method interval.  At an umbilic the truth lies on the line
  v = 0 and the coverage event is chi^2_2-distributed, so c rises to 5.99 there:
  c = crit(max(0, lambda - 2.448)), lambda the Mahalanobis length of v_hat and
  crit the 95 % quantile of (Rice(l) - l)^2 made non-increasing (``_CRIT``).
  For k1, k2 the umbilic truth is a point (the cone's vertex), so their
  radius^2 rises to chi^2_3 = 7.81 instead (``critical_value_k``).
- **Model bias** (optional): ``bias`` is a vector added in quadrature to the
  ellipsoid along its own direction (see ``api``: the difference to a
  higher-degree refit, kept only where it is significant).
- **Model bias** of the spline's curvature (``model_bias``, beyond the thesis): the refit of
  the constant-curvature surface, below.
"""

import numpy as np

from tactile.ep2.geometry import shape_entries, shape_index

Z95 = 1.959963984540054
CHI2_1_95 = 3.841458820694124
CHI2_2_95 = 5.991464547107979
CHI2_3_95 = 7.814727903251178
# 95 % quantile of (Rice(l) - l)^2 (unit sigma) for l = 0, 0.1, ..., 1.0, made
# non-increasing; chi^2_1 beyond (tests recompute it with scipy.stats.rice).
_CRIT = np.array([5.991, 5.541, 5.162, 4.847, 4.588, 4.375, 4.201, 4.059, 3.942, 3.845, CHI2_1_95])
K_UMBILIC = CHI2_2_95
_T_DB = np.array([[0.5, 0.0, -0.5], [0.0, 1.0, 0.0]])  # (a, b, c) -> v = ((a - c)/2, b)


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


def anisotropy(t, cov):
    """(m, h, lambda): mean curvature, debiased anisotropy |v|, Mahalanobis |v_hat|, for one
    patch (t (3,), cov (3, 3)) or a stack (t (B, 3), cov (B, 3, 3)): each () or (B,)."""
    t, cov = np.asarray(t, float), np.asarray(cov, float)
    a, b, c = np.moveaxis(t, -1, 0)
    m = 0.5 * (a + c)
    v = np.stack([0.5 * (a - c), b], axis=-1)
    cov_v = _T_DB @ cov @ _T_DB.T
    h = np.sqrt(np.maximum(np.sum(v * v, -1) - np.trace(cov_v, axis1=-2, axis2=-1), 0.0))
    return m, h, _mahalanobis(v, cov_v)


def critical_value(lam):
    """Ellipsoid radius^2 for 95 % coverage given the anisotropy's Mahalanobis length
    (a number or an array of them)."""
    x = np.maximum(0.0, np.asarray(lam, float) - np.sqrt(CHI2_2_95)) / 0.1
    out = np.interp(x, np.arange(_CRIT.size), _CRIT)
    return float(out) if out.ndim == 0 else out


def critical_value_k(lam):
    """The same for k1, k2 and |k|max: at an umbilic the truth is the vertex of the cone
    k = m -/+ h, a point of the 3-D tensor space, so the radius^2 rises toward chi^2_3 =
    7.81; ``K_UMBILIC`` (chi^2_2) is enough once the covariance counts the fit's bias
    (measured on the surface-family bench: chi^2_3 covers the sphere's k2 0.99 of the time)."""
    frac = (critical_value(lam) - CHI2_1_95) / (CHI2_2_95 - CHI2_1_95)
    return CHI2_1_95 + frac * (K_UMBILIC - CHI2_1_95)


def _mahalanobis(v, cov):
    """|v| in the metric of ``cov`` per problem: v (..., k), cov (..., k, k)."""
    w, V = np.linalg.eigh(cov)
    tiny = 1e-12 * np.maximum(w.max(axis=-1), 0.0) + 1e-300
    proj = np.einsum("...ij,...i->...j", V, v)
    return np.sqrt(np.sum(proj * proj / np.maximum(w, tiny[..., None]), axis=-1))


def _sphere_dirs(n=160):
    """n near-uniform unit vectors (Fibonacci lattice), (3, n)."""
    i = np.arange(n) + 0.5
    zc = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - zc * zc)
    phi = np.pi * (1.0 + 5**0.5) * i
    return np.vstack([r * np.cos(phi), r * np.sin(phi), zc])


_DIRS = _sphere_dirs()


def ellipsoid_points(t, cov, crits):
    """For each radius^2 in ``crits`` (each (B,)): (m, h, ok) at the boundary samples of
    each ellipsoid of the stack (t (B, 3), cov (B, 3, 3)) and where the umbilic axis
    a = c, b = 0 crosses it (those points have h = 0); ``ok`` marks the samples that exist
    (a gradient step or an axis crossing may not)."""
    w, V = np.linalg.eigh(cov)
    w = np.maximum(w, 0.0)
    steps, ok_steps = _gradient_steps(t, cov)
    unit = np.concatenate([(V * np.sqrt(w)[:, None, :]) @ _DIRS, steps], axis=-1)
    ok = np.concatenate([np.ones((len(t), _DIRS.shape[1]), bool), ok_steps], axis=-1)
    out = []
    for crit in crits:
        pts = t[:, :, None] + np.sqrt(crit)[:, None, None] * unit
        m = 0.5 * (pts[:, 0] + pts[:, 2])
        h = np.hypot(0.5 * (pts[:, 0] - pts[:, 2]), pts[:, 1])
        mu, ok_mu = _axis_crossing(t, w, V, crit)
        out.append(
            (
                np.concatenate([m, mu], axis=-1),
                np.concatenate([h, np.zeros_like(mu)], axis=-1),
                np.concatenate([ok, ok_mu], axis=-1),
            )
        )
    return out


def _gradient_steps(t, cov):
    """Unit-radius steps cov g / sqrt(g^T cov g) along the gradients g of m, h, k1, k2
    and S at t (both signs): where a locally linear quantity has its extremes, so the
    sampled range is never narrower than the delta-method interval.  (B, 3, 10) steps and
    (B, 10) which exist (h's gradients need h > 0; a step needs g^T cov g > 0)."""
    a, b, c = np.moveaxis(t, -1, 0)
    d = 0.5 * (a - c)
    h = np.hypot(d, b)
    pos = h > 0
    hs = np.where(pos, h, 1.0)
    gm = np.broadcast_to(np.array([0.5, 0.0, 0.5]), t.shape)
    gh = np.stack([0.5 * d / hs, b / hs, -0.5 * d / hs], axis=-1)
    m = 0.5 * (a + c)
    r = np.hypot(m, hs)[:, None]  # > 0; m^2 + h^2 itself underflows for curvatures near 1e-160
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        gs = ((hs[:, None] / r) * gm - (m[:, None] / r) * gh) / r
    grads = np.stack([gm, gh, gm + gh, gm - gh, gs], axis=1)  # (B, 5, 3)
    big = np.max(np.abs(grads), axis=-1)
    ok = (0 < big) & (big < np.inf)
    ok[:, 1:] &= pos[:, None]
    g = grads / np.where(ok, big, 1.0)[..., None]  # the step is scale-free in g
    g = np.where(ok[..., None], g, 0.0)
    cg = np.einsum("bij,bkj->bki", cov, g)
    n = np.sqrt(np.maximum(np.sum(g * cg, axis=-1), 0.0))
    ok &= n > 0
    step = cg / np.where(ok, n, 1.0)[..., None]
    steps = np.stack([step, -step], axis=2).reshape(len(t), 10, 3)  # +, - per gradient
    return np.swapaxes(steps, -1, -2), np.repeat(ok, 2, axis=1)


def _axis_crossing(t, w, V, crit):
    """Values mu (B, 2) where (mu, 0, mu) lies on each ellipsoid's boundary, and whether
    they exist (B, 2) (0 or 2 values)."""
    tiny = 1e-12 * np.maximum(w.max(axis=-1), 0.0) + 1e-300
    inv = (V / np.maximum(w, tiny[:, None])[:, None, :]) @ np.swapaxes(V, -1, -2)
    e = np.array([1.0, 0.0, 1.0])
    qa = np.einsum("i,bij,j->b", e, inv, e)
    qb = np.einsum("i,bij,bj->b", e, inv, t)
    qc = np.einsum("bi,bij,bj->b", t, inv, t) - crit
    disc = qb * qb - qa * qc
    ok = (disc >= 0) & (qa > 0)
    root = np.sqrt(np.where(ok, disc, 0.0))
    qa = np.where(ok, qa, 1.0)
    mu = np.stack([(qb - root) / qa, (qb + root) / qa], axis=-1)
    return mu, np.repeat(ok[:, None], 2, axis=1)


def intervals(t, cov, m, h, lam, bias=None):
    """95 % intervals for S, k1, k2 and kmax = |m| + h, each widened to hold the estimate.

    ``lam`` is the anisotropy's Mahalanobis length (``anisotropy``); ``bias`` a model-bias
    vector whose outer product is added to Cov, or None.  S uses ``critical_value(lam)``;
    k1, k2 and kmax use ``critical_value_k(lam)``.  One patch (t (3,), cov (3, 3), m, h,
    lam numbers, bias (3,)): each interval (2,), ``crit`` (); a stack (t (B, 3) ...): each
    (B, 2), ``crit`` (B,)."""
    one = np.ndim(t) == 1
    if one:  # a stack of one
        t, cov, bias = (None if x is None else np.asarray(x, float)[None] for x in (t, cov, bias))
        m, h, lam = (np.asarray(x, float).reshape(1) for x in (m, h, lam))
    if bias is not None:
        cov = cov + bias[:, :, None] * bias[:, None, :]
    crit_s = critical_value(lam)
    crit_k = critical_value_k(lam)
    (sm, sh, s_ok), (pm, ph, p_ok) = ellipsoid_points(t, cov, (crit_s, crit_k))
    S = shape_index(sm + sh, sm - sh)
    est = {"S": shape_index(m + h, m - h), "k1": m + h, "k2": m - h, "kmax": np.abs(m) + h}
    vals = {"S": (S, s_ok), "k1": (pm + ph, p_ok), "k2": (pm - ph, p_ok)}
    vals["kmax"] = (np.abs(pm) + ph, p_ok)
    out = {}
    for key, (v, ok) in vals.items():
        lo = np.minimum(np.where(ok, v, np.inf).min(axis=-1), est[key])
        hi = np.maximum(np.where(ok, v, -np.inf).max(axis=-1), est[key])
        out[key] = np.stack([lo, hi], axis=-1)
    # the origin inside the ellipsoid: kmax can be 0 (a plane is compatible)
    inside = _mahalanobis(t, cov) ** 2 <= crit_k
    out["kmax"][:, 0] = np.where(inside, 0.0, out["kmax"][:, 0])
    out["crit"] = crit_s
    return {k: v[0] for k, v in out.items()} if one else out


# --- Model bias of the patch curvature: refit of the constant-curvature surface.
#
# A biquadratic cannot follow a circle: on a cylinder of radius 8 over a 4 x 4
# patch its grid-mean curvature is ~1 % low, which at low noise is several
# standard deviations, so intervals from the noise alone miss the truth
# (docs/ep2.md, calibration).  The bias is estimated by fitting, with the same
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
