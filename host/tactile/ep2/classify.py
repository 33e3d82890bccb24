"""Shape labels with a confidence (§4.8.2, tables 1-3; beyond the thesis: intervals).

Labels: plane, sphere, cylinder, saddle, concave_cylinder, concave_sphere
(the S bands of ``shape_index.S_REGIONS``) or uncertain.

- plane: the curvedness is below what the data resolve.  The grid-mean shape
  operator t = (a, b, c) (symmetric 2x2 entries, so no k1 >= k2 ordering bias)
  is tested against zero: d^2 = t^T Cov(t)^-1 t with Cov(t) propagated from
  the coefficient covariance (``uncertainty.tensor_cov``); plane when
  d^2 < chi^2_3(99.9 %) = 16.27, or when R is below ``R_TOL`` relative to
  the patch size (the thesis's R < 1e-6, §4.8.1).
  S and C are then null.  Confidence = the test's p-value P(chi^2_3 > d^2):
  1 for an exactly flat fit, 0.001 at the edge of resolution.
- otherwise the patch S gives each S band a probability under a split normal
  whose two sds are the distances from S to the ends of its 95 % interval over
  the interval's critical radius (``vote``);
  confidence = that band's probability x (1 - p_flat), p_flat the flatness
  test's p-value (so a barely resolved curvature cannot give a confident
  label); the label is the band if the confidence reaches ``MIN_VOTE``, else
  ``uncertain``.
"""

import math

import numpy as np

from tactile.ep2.shape_index import S_EDGES, S_NAMES, s_class

R_TOL = 1e-6  # curvedness x patch size below which a patch is flat whatever the noise
MIN_VOTE = 0.999


CHI2_3_999 = 16.26623619623813  # chi^2 with 3 dof, 99.9 % quantile
_EDGES = (-math.inf, *S_EDGES.tolist(), math.inf)


def flatness_distance(tensor, cov):
    """Mahalanobis d^2 of the mean shape-operator entries from 0, per patch of a stack:
    tensor (B, 3), cov (B, 3, 3) -> (B,)."""
    diff = np.asarray(tensor, float)
    w, v = np.linalg.eigh(cov)
    keep = w > 1e-12 * np.maximum(w.max(axis=-1), 1e-300)[:, None]
    proj = np.where(keep, np.einsum("bij,bi->bj", v, diff), 0.0)
    rest = diff - np.einsum("bij,bj->bi", v, proj)
    d2 = np.sum(np.where(keep, proj * proj / np.where(keep, w, 1.0), 0.0), axis=-1)
    size = np.linalg.norm(diff, axis=-1)
    # curvature along a direction the data pin to zero spread
    d2 = np.where(np.linalg.norm(rest, axis=-1) > 1e-9 * np.maximum(size, 1e-300), np.inf, d2)
    return np.where(keep.any(axis=-1), d2, np.where(np.any(diff != 0, axis=-1), np.inf, 0.0))


def is_plane(r_mean, d2):
    """Plane test on R (relative to a unit patch) and on d^2 (None: no noise estimate)."""
    if r_mean <= R_TOL:
        return True
    return d2 is not None and d2 < CHI2_3_999


def plane_confidence(r_mean, d2):
    """p-value P(chi^2_3 > d^2) of 'flat'; 1 below the R tolerance."""
    if r_mean <= R_TOL or d2 is None:
        return 1.0
    x = float(d2)
    if not x < 1400.0:  # (beyond: 0 to double precision; NaN or inf: a singular covariance)
        return 0.0
    return float(math.erfc(math.sqrt(x / 2)) + math.sqrt(2 * x / math.pi) * math.exp(-x / 2))


def split_normal_cdf(x, mode, sd_lo, sd_hi):
    """CDF of the split normal: half-normals of sd ``sd_lo`` below and ``sd_hi`` above the mode,
    weighted so the density is continuous (a zero sd puts no mass on that side)."""
    total = sd_lo + sd_hi
    if x <= mode:
        if sd_lo <= 0:
            return 0.0
        return (sd_lo / total) * math.erfc((mode - x) / (sd_lo * math.sqrt(2)))
    if sd_hi <= 0:
        return 1.0
    return sd_lo / total + (sd_hi / total) * math.erf((x - mode) / (sd_hi * math.sqrt(2)))


def vote(s_est, s_sd, p_flat=0.0):
    """Label and confidence from the S distribution over the bands and the flatness p-value.

    ``s_sd`` is a standard deviation or a (below, above) pair: the S interval is
    asymmetric where S is bounded (a sphere's debiased S sits at 1 with the whole
    interval below it), and a symmetric normal there would put almost all the
    mass in the sphere band whatever the interval's width.
    """
    if not s_sd or not (any(s_sd) if type(s_sd) is tuple else np.any(s_sd)):
        return S_NAMES[int(s_class(s_est))], 1.0 - p_flat, {}
    lo, hi = (s_sd, s_sd) if np.isscalar(s_sd) else s_sd
    cdf = [split_normal_cdf(e, s_est, lo, hi) for e in _EDGES]
    # Python floats, the same arithmetic as np.diff; argmax as numpy's (first NaN, else
    # the first largest)
    shares = [(b - a) * (1.0 - p_flat) for a, b in zip(cdf, cdf[1:], strict=False)]
    nan = [i for i, v in enumerate(shares) if v != v]
    best = nan[0] if nan else shares.index(max(shares))
    votes = {S_NAMES[i]: float(c) for i, c in enumerate(shares) if c > 1e-4}
    if shares[best] >= MIN_VOTE:
        return S_NAMES[best], float(shares[best]), votes
    return "uncertain", float(shares[best]), votes
