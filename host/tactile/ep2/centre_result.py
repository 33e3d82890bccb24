"""From the curvature at the patch centre and its covariance to what a user is told: S, k1,
k2, radius and C with 95 % intervals and a label (``summary``, for a stack of patches), the
thesis's grid statistics and maps (§4.8.2).

The label: a plane where the curvature tensor cannot be told from 0 (a 99.9 % test; the
spline also asks both k intervals to hold 0); otherwise the S band holding 99.9 % of S's
distribution (``classify``), else ``uncertain``.  A plane has no S, C or radius.  Which
patches are refused is decided before, by the fit (``jet_answers``, ``spline_analysis``).
"""

import math

import numpy as np

from tactile.ep2 import classify, grid_batch, uncertainty
from tactile.ep2.shape_index import curvedness_c, curvedness_r, hk_labels, s_region_map, shape_index
from tactile.ep2.surface_geometry import eigen, shape_entries


def direction_text(d):
    """ "(x, y, z)" of a unit direction to two decimals; a component that rounds to zero is
    printed "0.00" whatever its sign (round-off differs between a batch and one patch)."""
    return "(" + ", ".join(f"{0.0 if abs(v) < 0.005 else v:.2f}" for v in d) + ")"


def summary(t, cov, bias, scale, intervals=True, cov_noise=None, plane_holds_zero=False):
    """Headline curvature at the centre, intervals and label (lengths / ``scale`` inside) of
    every patch of a stack: t (B, 3), cov and cov_noise (B, 3, 3), bias (B, 3) or None,
    scale (B,); a list of dicts.  The linear algebra runs on the whole stack.

    ``cov`` (floored, widened) sets the intervals and the tests; the anisotropy is debiased
    with ``cov_noise``, the estimate's own scatter (default ``cov``): a floor meant to keep
    intervals honest must not pull a low-noise estimate's k1 and k2 together.
    ``plane_holds_zero``: "plane" only where the k1 and k2 intervals both hold 0 (the
    spline's: its model bias widens the flatness test beyond its intervals)."""
    d2 = classify.flatness_distance(t, cov)
    k1s, k2s = eigen(*np.moveaxis(t, -1, 0))
    m, _, lam = uncertainty.anisotropy(t, cov)
    _, h, _ = uncertainty.anisotropy(t, cov if cov_noise is None else cov_noise)
    r = np.sqrt(0.5 * (k1s * k1s + k2s * k2s))
    plane = (r <= classify.R_TOL) | (d2 < classify.CHI2_3_999)  # ``classify.is_plane``
    raw = np.hypot(0.5 * (t[:, 0] - t[:, 2]), t[:, 1])
    # no debiasing where the curvature itself is not resolved
    iv = uncertainty.intervals(t, cov, m, np.where(plane, raw, h), lam, bias) if intervals else None
    if iv is not None and plane_holds_zero:
        curved = (r > classify.R_TOL) & _excludes_zero(iv)
        if np.any(plane & curved):
            plane &= ~curved
            iv = uncertainty.intervals(t, cov, m, np.where(plane, raw, h), lam, bias)
    h = np.where(plane, raw, h)
    c = curvedness_c(np.where(plane, 1.0, curvedness_r(k1s, k2s)) / scale)
    # Python numbers once for the stack (``tolist``: the same values as float(a[i]))
    m, h, scale, c = (np.asarray(v, float).tolist() for v in (m, h, scale, c))
    iv = None if iv is None else {k: np.asarray(v).tolist() for k, v in iv.items()}
    flat = zip(r.tolist(), d2.tolist(), plane.tolist(), strict=True)
    return [_summary_one(i, m, h, iv, f, scale, c) for i, f in enumerate(flat)]


def _excludes_zero(iv):
    """(B,) whether the k1 or the k2 interval leaves out 0."""
    k1, k2 = iv["k1"], iv["k2"]
    return (k1[:, 0] > 0) | (k1[:, 1] < 0) | (k2[:, 0] > 0) | (k2[:, 1] < 0)


def _summary_one(i, m, h, iv, flat, scale, c):
    """Patch ``i``'s fields of ``summary`` from its stack's numbers (lists); ``flat`` =
    (R, d^2, plane), ``c`` the curvedness C."""
    (r, d2, plane), scale = flat, scale[i]
    m, h = m[i], h[i]
    out = dict.fromkeys("S C radius S_interval radius_interval k1_interval k2_interval".split())
    out.update(k1=(m + h) / scale, k2=(m - h) / scale, votes={})
    if iv is not None:
        out["k1_interval"] = tuple(float(v) / scale for v in iv["k1"][i])
        out["k2_interval"] = tuple(float(v) / scale for v in iv["k2"][i])
    if plane:
        out.update(shape="plane", confidence=classify.plane_confidence(r, d2))
        return out
    s = float(shape_index(m + h, m - h))
    sd = None
    if iv is not None:
        root = math.sqrt(float(iv["crit"][i]))
        s_iv = tuple(float(v) for v in iv["S"][i])
        sd = ((s - s_iv[0]) / root, (s_iv[1] - s) / root)
        out["S_interval"] = s_iv
        lo, hi = (float(v) for v in iv["kmax"][i])
        out["radius_interval"] = (scale / hi if hi > 0 else None, scale / lo if lo > 0 else None)
    p_flat = classify.plane_confidence(r, d2)
    out["shape"], out["confidence"], out["votes"] = classify.vote(s, sd, p_flat)
    kmax = max(abs(m + h), abs(m - h))
    out.update(S=s, radius=scale / kmax, C=float(c[i]))
    return out


def grid_statistics(channels, scale, plane):
    """The thesis's grid statistics (§4.8.2) of one patch's grid channels (each (N^2,)):
    ``grid_batch.statistics`` for a stack of one."""
    stats = grid_batch.statistics([np.asarray(c)[None] for c in channels], np.array([scale]))
    return grid_batch.at(stats, 0, scale, plane)


def maps(channels, gx, gy, scale, plane, hk_eps):
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
