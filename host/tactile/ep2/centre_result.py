"""From the curvature at the patch centre and its covariance to what a user is told: S, k1,
k2, radius and C with 95 % intervals and a label (``summary``, for a stack of patches: a
``Centre`` each), and what both methods hand ``api.PatchResult`` (``Answer``).

The label: a plane where the curvature tensor cannot be told from 0 (a 99.9 % test; the
spline also asks both k intervals to hold 0); otherwise the S band holding 99.9 % of S's
distribution (``vote``), else ``uncertain``.  A plane has no S, C or radius.  Which
patches are refused is decided before, by the fit (``jet_answers``, ``spline_answers``).

The curvature is summarised by t = (a, b, c), the symmetric shape-operator entries
(``geometry.shape_entries``): m = (a + c)/2 the mean curvature, v = ((a - c)/2, b) the
anisotropy, h = |v|, k1,2 = m +/- h, S = (2/pi) atan2(m, h) (§2.4).

- **Debiased anisotropy.**  E|v_hat|^2 = |v|^2 + tr Cov(v), so the plug-in h is biased
  up (a noisy sphere looks anisotropic); the estimate uses h^2 = max(|v_hat|^2 - tr
  Cov(v), 0), the Rician bias correction.
- **Intervals** (``ellipsoid_intervals``) project the confidence ellipsoid
  {t : (t - t_hat)^T Cov^-1 (t - t_hat) <= c} onto each quantity (boundary sampled, plus
  where the umbilic axis h = 0 pierces it).  For a smooth quantity c = chi^2_1(95 %) =
  3.84, the delta-method interval.  At an umbilic the coverage event is chi^2_2, so c
  rises to 5.99 there: c = crit(max(0, lambda - 2.448)), lambda the Mahalanobis length of
  v_hat and crit the 95 % quantile of (Rice(l) - l)^2 made non-increasing (``_CRIT``);
  for k1, k2 the umbilic truth is a point, so chi^2_3 = 7.81 (``critical_value_k``).
  ``bias`` is added in quadrature along its own direction (the spline's model bias,
  ``spline_answers.model_bias``).
"""

import math
from dataclasses import dataclass

import numpy as np

from tactile.ep2.geometry import (
    S_EDGES,
    S_NAMES,
    GridStats,
    PatchFrame,
    curvedness_c,
    curvedness_r,
    eigen,
    s_class,
    shape_index,
)


@dataclass
class Centre:
    """The curvature at the patch centre as a user is told it (``summary``): label,
    confidence, S, k1, k2, radius, C and their 95 % intervals (input unit; None where a
    plane has none, or without intervals), the S bands' votes."""

    shape: str
    confidence: float
    S: float | None
    k1: float
    k2: float
    radius: float | None
    C: float | None
    S_interval: tuple | None
    k1_interval: tuple | None
    k2_interval: tuple | None
    radius_interval: tuple | None
    votes: dict


@dataclass
class Intervals:
    """95 % intervals (``ellipsoid_intervals``), in units of the patch: S, k1, k2 and kmax =
    |m| + h, each (lo, hi) per patch of a stack, and S's ellipsoid radius^2 ``crit``."""

    S: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    kmax: np.ndarray
    crit: np.ndarray


@dataclass
class Answer:
    """What a method found for one patch (``jet_answers.outcomes``, ``spline_answers.analyze``)
    and ``api.PatchResult`` is made of.  ``frame``: about the centred contacts; ``surface``:
    z(xy / L) / L; ``grid``: the grid's channels and points (for the maps); ``direction1``:
    world; ``box``: the contacts' in the frame / L; ``fit``: the B-spline's."""

    centre: Centre
    stats: GridStats
    model: str
    order: int
    weighting: str
    noise_pos: float | None
    noise_normal: float | None
    frame: PatchFrame
    scale: float
    surface: object
    grid: tuple
    direction1: np.ndarray
    box: tuple
    warnings: list
    fit: object = None


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
    eig = np.linalg.eigh(cov)  # (once: the flatness test and the intervals share it)
    d2 = flatness_distance(t, cov, eig)
    k1s, k2s = eigen(*np.moveaxis(t, -1, 0))
    m, _, lam = anisotropy(t, cov)
    _, h, _ = anisotropy(t, cov if cov_noise is None else cov_noise)
    r = np.sqrt(0.5 * (k1s * k1s + k2s * k2s))
    plane = (r <= R_TOL) | (d2 < CHI2_3_999)  # ``is_plane``
    raw = np.hypot(0.5 * (t[:, 0] - t[:, 2]), t[:, 1])
    # no debiasing where the curvature itself is not resolved
    hs = np.where(plane, raw, h)
    iv = ellipsoid_intervals(t, cov, m, hs, lam, bias, eig) if intervals else None
    if iv is not None and plane_holds_zero:
        curved = (r > R_TOL) & _excludes_zero(iv)
        if np.any(plane & curved):
            plane &= ~curved
            iv = ellipsoid_intervals(t, cov, m, np.where(plane, raw, h), lam, bias, eig)
    h = np.where(plane, raw, h)
    c = curvedness_c(np.where(plane, 1.0, curvedness_r(k1s, k2s)) / scale)
    # Python numbers once for the stack (``tolist``: the same values as float(a[i]))
    m, h = np.asarray(m, float), np.asarray(h, float)
    s = shape_index(m + h, m - h)
    p_flat = [plane_confidence(a, b) for a, b in zip(r.tolist(), d2.tolist(), strict=True)]
    voted = dict.fromkeys(range(len(t)))  # (the curved patches' votes, where intervals)
    if iv is not None:
        curved = np.flatnonzero(~plane)
        root = np.sqrt(iv.crit[curved])
        sd = ((s[curved] - iv.S[curved, 0]) / root, (iv.S[curved, 1] - s[curved]) / root)
        voted.update(zip(curved.tolist(), votes(s[curved], *sd, np.take(p_flat, curved))))
    m, h, scale, c, s = (np.asarray(v, float).tolist() for v in (m, h, scale, c, s))
    iv = iv and Intervals(**{k: np.asarray(v).tolist() for k, v in vars(iv).items()})
    flat = zip(p_flat, plane.tolist(), s, voted.values(), strict=True)
    return [_summary_one(i, m, h, iv, f, scale, c) for i, f in enumerate(flat)]


def _excludes_zero(iv):
    """(B,) whether the k1 or the k2 interval leaves out 0."""
    k1, k2 = iv.k1, iv.k2
    return (k1[:, 0] > 0) | (k1[:, 1] < 0) | (k2[:, 0] > 0) | (k2[:, 1] < 0)


def _summary_one(i, m, h, iv, flat, scale, c):
    """Patch ``i``'s ``Centre`` from its stack's numbers (lists); ``flat`` = (the flatness
    test's p-value, plane, S, the S vote (``votes``) or None), ``c`` the curvedness C."""
    (p_flat, plane, s, voted), scale = flat, scale[i]
    m, h = m[i], h[i]
    out = Centre(None, None, None, (m + h) / scale, (m - h) / scale, None, None, None, None,
                 None, None, {})  # fmt: skip
    if iv is not None:  # (Python floats: ``summary``'s ``tolist``)
        (lo1, hi1), (lo2, hi2) = iv.k1[i], iv.k2[i]
        out.k1_interval, out.k2_interval = (lo1 / scale, hi1 / scale), (lo2 / scale, hi2 / scale)
    if plane:
        out.shape, out.confidence = "plane", p_flat
        return out
    if iv is not None:
        out.S_interval = tuple(iv.S[i])
        lo, hi = iv.kmax[i]
        out.radius_interval = (scale / hi if hi > 0 else None, scale / lo if lo > 0 else None)
    out.shape, out.confidence, out.votes = voted or vote(s, None, p_flat)
    kmax = max(abs(m + h), abs(m - h))
    out.S, out.radius, out.C = s, scale / kmax, float(c[i])
    return out


# --- Shape labels with a confidence (§4.8.2, tables 1-3; beyond the thesis: intervals).
#
# Labels: plane, sphere, cylinder, saddle, concave_cylinder, concave_sphere (the S bands of
# ``geometry.S_REGIONS``) or uncertain.
#
# - plane: the curvedness is below what the data resolve. The grid-mean shape operator t = (a, b,
# c) (symmetric 2x2 entries, so no k1 >= k2 ordering bias) is tested against zero: d^2 = t^T
# Cov(t)^-1 t with Cov(t) propagated from the coefficient covariance (``tensor_cov``);
# plane when d^2 < chi^2_3(99.9 %) = 16.27, or when R is below ``R_TOL`` relative to the patch
# size (the thesis's R < 1e-6, §4.8.1). S and C are then null. Confidence = the test's p-value
# P(chi^2_3 > d^2): 1 for an exactly flat fit, 0.001 at the edge of resolution. - otherwise the
# patch S gives each S band a probability under a split normal whose two sds are the distances
# from S to the ends of its 95 % interval over the interval's critical radius (``vote``);
# confidence = that band's probability x (1 - p_flat), p_flat the flatness test's p-value (so a
# barely resolved curvature cannot give a confident label); the label is the band if the
# confidence reaches ``MIN_VOTE``, else ``uncertain``.


R_TOL = 1e-6  # curvedness x patch size below which a patch is flat whatever the noise
MIN_VOTE = 0.999


CHI2_3_999 = 16.26623619623813  # chi^2 with 3 dof, 99.9 % quantile
_EDGES = (-math.inf, *S_EDGES.tolist(), math.inf)


def flatness_distance(tensor, cov, eig=None):
    """Mahalanobis d^2 of the mean shape-operator entries from 0, per patch of a stack:
    tensor (B, 3), cov (B, 3, 3) -> (B,); ``eig``: cov's ``eigh``, where known."""
    diff = np.asarray(tensor, float)
    w, v = np.linalg.eigh(cov) if eig is None else eig
    keep = w > 1e-12 * np.maximum(w.max(axis=-1), 1e-300)[:, None]
    proj = np.where(keep, np.einsum("bij,bi->bj", v, diff), 0.0)
    rest = diff - np.einsum("bij,bj->bi", v, proj)
    d2 = np.sum(np.where(keep, proj * proj / np.where(keep, w, 1.0), 0.0), axis=-1)
    size = np.linalg.norm(diff, axis=-1)
    # curvature along a direction the data pin to zero spread
    d2 = np.where(np.linalg.norm(rest, axis=-1) > 1e-9 * np.maximum(size, 1e-300), np.inf, d2)
    return np.where(keep.any(axis=-1), d2, np.where(np.any(diff != 0, axis=-1), np.inf, 0.0))


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
    lo, hi = s_sd if type(s_sd) is tuple or not np.isscalar(s_sd) else (s_sd, s_sd)
    return votes([s_est], [lo], [hi], [p_flat])[0]


def votes(s, sd_lo, sd_hi, p_flat):
    """``vote`` of a stack (``vote`` with an sd is this of one): S, its sds below and above
    it, the flatness p-values (each (B,)); ``split_normal_cdf`` at each band edge on arrays
    (``math.erf``/``erfc`` of each point, so each number is its own), each band's share,
    argmax as NumPy's (the first NaN, else the first largest); a list of (label,
    confidence, votes)."""
    s, lo, hi, p_flat = (np.asarray(v, float)[:, None] for v in (s, sd_lo, sd_hi, p_flat))
    below = _EDGE_ARRAY <= s  # (``split_normal_cdf``'s branches)
    total = lo + hi
    with np.errstate(divide="ignore", invalid="ignore"):
        arg = np.where(below, (s - _EDGE_ARRAY) / (lo * _ROOT2), (_EDGE_ARRAY - s) / (hi * _ROOT2))
        pairs = zip(arg.ravel().tolist(), below.ravel().tolist(), strict=True)
        e = np.array([math.erfc(a) if b else math.erf(a) for a, b in pairs]).reshape(arg.shape)
        cdf = np.where(below, np.where(lo <= 0, 0.0, (lo / total) * e),
                       np.where(hi <= 0, 1.0, lo / total + (hi / total) * e))  # fmt: skip
    shares = (cdf[:, 1:] - cdf[:, :-1]) * (1.0 - p_flat)
    best = np.argmax(shares, axis=1).tolist()  # (the first NaN, else the first largest)
    none = ((lo == 0) & (hi == 0))[:, 0].tolist()  # (``vote``: no spread, the band of S)
    out = []
    for k, row in enumerate(shares.tolist()):
        if none[k]:
            out.append((S_NAMES[int(s_class(s[k, 0]))], 1.0 - float(p_flat[k, 0]), {}))
            continue
        share = row[best[k]]
        picked = {S_NAMES[i]: c for i, c in enumerate(row) if c > 1e-4}
        out.append((S_NAMES[best[k]] if share >= MIN_VOTE else "uncertain", share, picked))
    return out


_EDGE_ARRAY = np.array(_EDGES)
_ROOT2 = math.sqrt(2)


CHI2_1_95 = 3.841458820694124
CHI2_2_95 = 5.991464547107979
# 95 % quantile of (Rice(l) - l)^2 (unit sigma) for l = 0, 0.1, ..., 1.0, made
# non-increasing; chi^2_1 beyond (tests recompute it with scipy.stats.rice).
_CRIT = np.array([5.991, 5.541, 5.162, 4.847, 4.588, 4.375, 4.201, 4.059, 3.942, 3.845, CHI2_1_95])
K_UMBILIC = CHI2_2_95
_T_DB = np.array([[0.5, 0.0, -0.5], [0.0, 1.0, 0.0]])  # (a, b, c) -> v = ((a - c)/2, b)


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


def _mahalanobis(v, cov, eig=None):
    """|v| in the metric of ``cov`` per problem: v (..., k), cov (..., k, k)."""
    w, V = np.linalg.eigh(cov) if eig is None else eig
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


def ellipsoid_points(t, cov, crits, eig=None):
    """For each radius^2 in ``crits`` (each (B,)): (m, h, ok) at the boundary samples of
    each ellipsoid of the stack (t (B, 3), cov (B, 3, 3)) and where the umbilic axis
    a = c, b = 0 crosses it (those points have h = 0); ``ok`` marks the samples that exist
    (a gradient step or an axis crossing may not); ``eig``: cov's ``eigh``, where known."""
    w, V = np.linalg.eigh(cov) if eig is None else eig
    w = np.maximum(w, 0.0)
    steps, ok_steps = _gradient_steps(t, cov)
    unit = np.concatenate([(V * np.sqrt(w)[:, None, :]) @ _DIRS, steps], axis=-1)
    ok = np.concatenate([np.ones((len(t), _DIRS.shape[1]), bool), ok_steps], axis=-1)
    out = []
    for crit in crits:
        pts = t[:, :, None] + np.sqrt(crit)[:, None, None] * unit
        m = 0.5 * (pts[:, 0] + pts[:, 2])
        h = _norm2(0.5 * (pts[:, 0] - pts[:, 2]), pts[:, 1])
        mu, ok_mu = _axis_crossing(t, w, V, crit)
        out.append(
            (
                np.concatenate([m, mu], axis=-1),
                np.concatenate([h, np.zeros_like(mu)], axis=-1),
                np.concatenate([ok, ok_mu], axis=-1),
            )
        )
    return out


def _norm2(a, b):
    """hypot(a, b), by sqrt(a^2 + b^2) (a tenth of hypot's cost) where no square of the
    stack under- or overflows, else by hypot."""
    big = np.maximum(np.abs(a), np.abs(b))
    if big.size and 1e-150 < big.min() and big.max() < 1e150:
        return np.sqrt(a * a + b * b)
    return np.hypot(a, b)


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


def ellipsoid_intervals(t, cov, m, h, lam, bias=None, eig=None):
    """95 % intervals for S, k1, k2 and kmax = |m| + h, each widened to hold the estimate.

    ``lam`` is the anisotropy's Mahalanobis length (``anisotropy``); ``bias`` a model-bias
    vector whose outer product is added to Cov, or None.  S uses ``critical_value(lam)``;
    k1, k2 and kmax use ``critical_value_k(lam)``.  One patch (t (3,), cov (3, 3), m, h,
    lam numbers, bias (3,)): each interval (2,), ``crit`` (); a stack (t (B, 3) ...): each
    (B, 2), ``crit`` (B,).  ``eig``: cov's ``eigh`` (a stack's, without bias), where known."""
    one = np.ndim(t) == 1
    if one:  # a stack of one
        t, cov, bias = (None if x is None else np.asarray(x, float)[None] for x in (t, cov, bias))
        m, h, lam = (np.asarray(x, float).reshape(1) for x in (m, h, lam))
    if bias is not None:
        cov, eig = cov + bias[:, :, None] * bias[:, None, :], None
    crit_s = critical_value(lam)
    crit_k = critical_value_k(lam)
    (sm, sh, s_ok), (pm, ph, p_ok) = ellipsoid_points(t, cov, (crit_s, crit_k), eig)
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
    inside = _mahalanobis(t, cov, eig) ** 2 <= crit_k
    out["kmax"][:, 0] = np.where(inside, 0.0, out["kmax"][:, 0])
    iv = Intervals(**out, crit=crit_s)
    return Intervals(**{k: v[0] for k, v in vars(iv).items()}) if one else iv
