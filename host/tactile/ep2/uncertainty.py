"""Patch-level curvature, its covariance, and 95 % intervals for S, k1, k2 and |k|max.

The patch is summarised by the grid mean t = (a, b, c) of the symmetric
shape-operator entries (``surface_geometry.shape_entries``): m = (a + c)/2 is
the mean curvature, v = ((a - c)/2, b) the anisotropy, h = |v|, and
k1,2 = m +/- h, S = (2/pi) atan2(m, h) (§2.4).

- **Covariance.**  t is a smooth function of the spline coefficients, so
  Cov(t) = s^2 (G F)(G F)^T with G = dt/dcoef (complex-step derivative along
  the five derivative channels, exact to round-off) and F the coefficients'
  covariance factor.  No Monte Carlo.
- **Debiased anisotropy.**  E|v_hat|^2 = |v|^2 + tr Cov(v), so the plug-in h is
  biased up: a noisy sphere always looks anisotropic (S < 1, k2 < k1).  The
  estimate uses h^2 = max(|v_hat|^2 - tr Cov(v), 0) (the Rician bias correction);
  it cuts the sphere's RMS S error by ~40 % (bench/ep2_peers.py).
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
"""

import numpy as np

Z95 = 1.959963984540054
CHI2_1_95 = 3.841458820694124
CHI2_2_95 = 5.991464547107979
CHI2_3_95 = 7.814727903251178
# 95 % quantile of (Rice(l) - l)^2 (unit sigma) for l = 0, 0.1, ..., 1.0, made
# non-increasing; chi^2_1 beyond (tests recompute it with scipy.stats.rice).
_CRIT = np.array([5.991, 5.541, 5.162, 4.847, 4.588, 4.375, 4.201, 4.059, 3.942, 3.845, CHI2_1_95])
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
    from tactile.ep2.surface_geometry import shape_entries

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
    """(m, h, lambda): mean curvature, debiased anisotropy |v|, Mahalanobis |v_hat|."""
    a, b, c = t
    m = 0.5 * (a + c)
    v = np.array([0.5 * (a - c), b])
    cov_v = _T_DB @ cov @ _T_DB.T
    h = float(np.sqrt(max(v @ v - np.trace(cov_v), 0.0)))
    return float(m), h, _mahalanobis(v, cov_v)


def critical_value(lam):
    """Ellipsoid radius^2 for 95 % coverage given the anisotropy's Mahalanobis length."""
    x = max(0.0, lam - np.sqrt(CHI2_2_95)) / 0.1
    return float(np.interp(x, np.arange(_CRIT.size), _CRIT))


def critical_value_k(lam):
    """The same for k1, k2 and |k|max: at an umbilic the truth is the vertex of the cone
    k = m -/+ h, a point of the 3-D tensor space, so the radius^2 rises to chi^2_3 = 7.81
    (measured: chi^2_2 there covers the sphere's k2 only 86-91 %)."""
    frac = (critical_value(lam) - CHI2_1_95) / (CHI2_2_95 - CHI2_1_95)
    return CHI2_1_95 + frac * (CHI2_3_95 - CHI2_1_95)


def _mahalanobis(v, cov):
    w, V = np.linalg.eigh(cov)
    tiny = 1e-12 * max(float(w.max()), 0.0) + 1e-300
    proj = V.T @ v
    return float(np.sqrt(np.sum(proj * proj / np.maximum(w, tiny))))


def _sphere_dirs(n=160):
    """n near-uniform unit vectors (Fibonacci lattice), (3, n)."""
    i = np.arange(n) + 0.5
    zc = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - zc * zc)
    phi = np.pi * (1.0 + 5**0.5) * i
    return np.vstack([r * np.cos(phi), r * np.sin(phi), zc])


_DIRS = _sphere_dirs()


def ellipsoid_points(t, cov, crits):
    """For each radius^2 in ``crits``: (m, h) at the boundary samples of the ellipsoid
    and where the umbilic axis a = c, b = 0 crosses it (those points have h = 0)."""
    w, V = np.linalg.eigh(cov)
    w = np.maximum(w, 0.0)
    unit = np.hstack([(V * np.sqrt(w)) @ _DIRS, _gradient_steps(t, cov)])
    out = []
    for crit in crits:
        pts = t[:, None] + np.sqrt(crit) * unit
        m = 0.5 * (pts[0] + pts[2])
        h = np.hypot(0.5 * (pts[0] - pts[2]), pts[1])
        mu = _axis_crossing(t, w, V, crit)
        out.append((np.concatenate([m, mu]), np.concatenate([h, np.zeros(mu.size)])))
    return out


def _gradient_steps(t, cov):
    """Unit-radius steps cov g / sqrt(g^T cov g) along the gradients g of m, h, k1, k2
    and S at t (both signs): where a locally linear quantity has its extremes, so the
    sampled range is never narrower than the delta-method interval."""
    a, b, c = t
    d = 0.5 * (a - c)
    h = np.hypot(d, b)
    gm = np.array([0.5, 0.0, 0.5])
    grads = [gm]
    if h > 0:
        gh = np.array([0.5 * d / h, b / h, -0.5 * d / h])
        m = 0.5 * (a + c)
        r = np.hypot(m, h)  # > 0; m^2 + h^2 itself underflows for curvatures near 1e-160
        gs = ((h / r) * gm - (m / r) * gh) / r
        grads += [gh, gm + gh, gm - gh, gs]
    steps = []
    for g in grads:
        big = np.max(np.abs(g))
        if not 0 < big < np.inf:
            continue
        g = g / big  # the step is scale-free in g, and gs grows like 1/curvature
        cg = cov @ g
        n = np.sqrt(max(float(g @ cg), 0.0))
        if n > 0:
            steps += [cg / n, -cg / n]
    return np.array(steps).T if steps else np.zeros((3, 0))


def _axis_crossing(t, w, V, crit):
    """Values mu where (mu, 0, mu) lies on the ellipsoid boundary (0 or 2 values)."""
    tiny = 1e-12 * max(float(w.max()), 0.0) + 1e-300
    inv = (V / np.maximum(w, tiny)) @ V.T
    e = np.array([1.0, 0.0, 1.0])
    qa = e @ inv @ e
    qb = e @ inv @ t
    qc = t @ inv @ t - crit
    disc = qb * qb - qa * qc
    if not disc >= 0 or not qa > 0:
        return np.empty(0)
    root = np.sqrt(disc)
    return np.array([(qb - root) / qa, (qb + root) / qa])


def intervals(t, cov, m, h, lam, bias=None):
    """95 % intervals for S, k1, k2 and kmax = |m| + h, each widened to hold the estimate.

    ``lam`` is the anisotropy's Mahalanobis length (``anisotropy``); ``bias``
    (3,) or None a model-bias vector whose outer product is added to Cov.
    S uses ``critical_value(lam)``; k1, k2 and kmax use ``critical_value_k(lam)``.
    """
    from tactile.ep2.shape_index import shape_index

    if bias is not None:
        cov = cov + np.outer(bias, bias)
    crit_s = critical_value(lam)
    crit_k = critical_value_k(lam)
    (sm, sh), (pm, ph) = ellipsoid_points(t, cov, (crit_s, crit_k))
    S = shape_index(sm + sh, sm - sh)
    est = {"S": float(shape_index(m + h, m - h)), "k1": m + h, "k2": m - h, "kmax": abs(m) + h}
    vals = {"S": S, "k1": pm + ph, "k2": pm - ph, "kmax": np.abs(pm) + ph}
    out = {}
    for key, v in vals.items():
        out[key] = (float(min(v.min(), est[key])), float(max(v.max(), est[key])))
    # the origin inside the ellipsoid: kmax can be 0 (a plane is compatible)
    if _mahalanobis(t, cov) ** 2 <= crit_k:
        out["kmax"] = (0.0, out["kmax"][1])
    out["crit"] = crit_s
    return out
