"""From a centre-jet fit (``local_jet``) to what a user is told: or why nothing is told.

Per patch (each step runs on a whole stack of patches, with the same numbers for a
patch alone or in a batch), in order:

1. **Determined?**  The 95 % half-width of the curvature in the worst
   direction (largest eigenvalue of Cov(t), model-choice bias included) must
   stay below 1/L: wider, and the data cannot tell a plane from a radius
   comparable to the patch, whatever the label.  A single line (in any
   direction), two nearly coincident lines or a cluster that leaves one
   direction unsampled fails here and is refused (``DataError``, exit 3)
   naming that direction.  No geometric special case: the covariance carries it.
2. **Consistent?**  The positions and the normals must describe one surface
   (``consistency``, tested before 1.).
3. **Intervals and label** (``uncertainty``, ``classify``): Cov is widened by
   the F quantile for its estimated noise (Satterthwaite degrees of
   freedom), the anisotropy is debiased where the curvature is resolved, and
   the label comes from the band mass of S.  A plane (curvature not told from
   0) has no S, C or radius.
"""

import math

import numpy as np

from tactile.ep2 import classify, grid_batch, jet_basis, uncertainty
from tactile.ep2.shape_index import curvedness_c, curvedness_r, hk_labels, s_region_map, shape_index
from tactile.ep2.surface_geometry import eigen, principal, shape_entries

MAX_HALF_WIDTH = 0.25  # x 1/L: the curvature's 95 % half-width beyond which it is not determined
MIN_SPREAD = 5.0  # the contacts' spread in their thinnest direction, in position-noise sds
PATH_PLANE_DEG = 45.0  # contacts in one plane tilted further than this from the surface: one path


def widen(nu, q=3, p=0.95):
    """Factor on Cov for a noise estimated with ``nu`` degrees of freedom: q F(q, nu) / chi^2_q
    (1 for a stated noise, nu = inf).  ``nu`` a number or an array."""
    from scipy.special import fdtri  # (here: only the spline needs it, 0.2 s to import)

    nu = np.asarray(nu, float)
    chi2 = {1: uncertainty.CHI2_1_95, 2: uncertainty.CHI2_2_95, 3: uncertainty.CHI2_3_95}[q]
    finite = np.isfinite(nu)
    out = np.where(finite, q * fdtri(q, np.maximum(np.where(finite, nu, 1.0), 1.0), p) / chi2, 1.0)
    return float(out) if out.ndim == 0 else out


def direction_text(d):
    """ "(x, y, z)" of a unit direction to two decimals; a component that rounds to zero is
    printed "0.00" whatever its sign (round-off differs between a batch and one patch)."""
    return "(" + ", ".join(f"{0.0 if abs(v) < 0.005 else v:.2f}" for v in d) + ")"


def determination(cov, axes, scale, spread, noise_pos):
    """None, or why the curvature is not determined (worst direction in world coordinates).

    Three limits, all on data rather than on the fit: ``spread`` = (contacts (n, 3) in the
    mean-normal frame / L, that frame's axes).

    - their spread across their thinnest tangent direction: under ``MIN_SPREAD``
      position-noise sds the positions are noise there, and the jet's regressors with them;
    - their thickness out of the best plane through them, where that plane stands across
      the surface (normal over ``PATH_PLANE_DEG`` from the mean normal): one finger's path
      over a curved surface is a planar curve that bends in the tangent frame by its own
      sagitta, so it passes the first test, yet curvature across it is only "seen" through
      the model's truncation (found by the property test, a line off a sphere's apex);
    - the curvature's 95 % half-width in its worst direction (``MAX_HALF_WIDTH`` / L).
    """
    w = np.linalg.eigvalsh(cov)  # noise only: the model-choice bias is bounded, not unknown
    half = 1.96 * math.sqrt(max(float(w[-1]), 0.0))
    (w2, v2, w3, v3), mean_axes = spread  # from data, not a fit (``spread_eigen``)
    sigma = max(noise_pos / scale, 1e-3)
    why = _thin_line(w2, v2, mean_axes, scale, sigma)
    why = why or _one_path_plane(w3, v3, mean_axes, scale, sigma)
    if why is not None:
        return why
    if half <= MAX_HALF_WIDTH:
        return None
    # curvature along u = (cos th, sin th): a cos^2 + 2 b cos sin + c sin^2; worst th
    th = np.linspace(0.0, np.pi, 181)[:-1]
    u = np.stack([np.cos(th) ** 2, 2 * np.cos(th) * np.sin(th), np.sin(th) ** 2])
    worst = th[int(np.argmax(np.einsum("in,ij,jn->n", u, cov, u)))]
    d = np.cos(worst) * axes[0] + np.sin(worst) * axes[1]
    return (
        f"curvature along {direction_text(d)} is not determined: its 95 %"
        f" interval is +/- {half / scale:.3g} per unit length, over {MAX_HALF_WIDTH:g}/L"
        f" (L = {scale:.4g}); the contacts do not span that direction well (near one line,"
        " lines too close, or bunched): sweep across it"
    )


def determination_many(cov, axes, scale, spread, noise_pos):
    """``determination`` of every patch of a stack (cov (B, 3, 3), axes (B, 3, 3), scale and
    noise_pos (B,), spread as ``spread_eigen`` gives it with the axes (B, 3, 3)): its three
    tests on the whole stack, the message written for the patches that fail one."""
    half = 1.96 * np.sqrt(np.maximum(np.linalg.eigvalsh(cov)[:, -1], 0.0))
    (w2, v2, w3, v3), mean_axes = spread
    floor = MIN_SPREAD * np.maximum(noise_pos / scale, 1e-3)
    thin = np.sqrt(np.maximum(w2[:, 0], 0.0)) >= floor
    apart = np.sqrt(np.maximum(w3[:, 0], 0.0)) >= floor
    apart |= np.abs(v3[:, 2, 0]) >= math.cos(math.radians(PATH_PLANE_DEG))
    fine = thin & apart & (half <= MAX_HALF_WIDTH)
    return [
        None
        if fine[i]
        else determination(
            cov[i], axes[i], scale[i], ((w2[i], v2[i], w3[i], v3[i]), mean_axes[i]), noise_pos[i]
        )
        for i in range(len(cov))
    ]


def spread_eigen(xyz, mask):
    """Eigen-decompositions (ascending) of the contacts' covariance in the mean-normal frame
    (``xyz`` (B, n, 3) / L, ``mask`` (B, n)), tangent 2 x 2 block and full 3 x 3, per patch:
    (w2 (B, 2), v2 (B, 2, 2), w3 (B, 3), v3 (B, 3, 3)) for ``determination``."""
    count = np.maximum(mask.sum(axis=1), 1)[:, None]
    centred = np.where(
        mask[..., None], xyz - (xyz * mask[..., None]).sum(axis=1)[:, None] / count[..., None], 0.0
    )
    cov = np.swapaxes(centred, 1, 2) @ centred / count[..., None]
    w2, v2 = np.linalg.eigh(cov[:, :2, :2])
    w3, v3 = np.linalg.eigh(cov)
    return w2, v2, w3, v3


def _thin_line(spread_w, spread_v, mean_axes, scale, sigma):
    thin = math.sqrt(max(float(spread_w[0]), 0.0))
    if thin >= MIN_SPREAD * sigma:
        return None
    d = spread_v[0, 0] * mean_axes[0] + spread_v[1, 0] * mean_axes[1]
    return (
        f"curvature across {direction_text(d)} is not determined: the"
        f" contacts lie near one line, spread only {thin * scale:.3g} across it, under"
        f" {MIN_SPREAD:g} times their position noise ({sigma * scale:.3g}): sweep across it"
    )


def _one_path_plane(w, v, mean_axes, scale, sigma):
    thick, p = math.sqrt(max(float(w[0]), 0.0)), v[:, 0]
    if thick >= MIN_SPREAD * sigma or abs(p[2]) >= math.cos(math.radians(PATH_PLANE_DEG)):
        return None
    d = p[0] * mean_axes[0] + p[1] * mean_axes[1]
    d = d / np.linalg.norm(d)
    tilt = math.degrees(math.acos(min(abs(float(p[2])), 1.0)))
    return (
        f"curvature across {direction_text(d)} is not determined: the"
        f" contacts lie in one plane standing {tilt:.0f} deg from the surface (one path), within"
        f" {thick * scale:.3g} of it, under {MIN_SPREAD:g} times their position noise"
        f" ({sigma * scale:.3g}): sweep across it"
    )


def summary(t, cov, bias, scale, intervals=True, cov_noise=None, plane_holds_zero=False):
    """Headline curvature at the centre, intervals and label (lengths / ``scale`` inside).

    ``cov`` (floored, widened) sets the intervals and the tests; the anisotropy is debiased
    with ``cov_noise``, the estimate's own scatter (default ``cov``): a floor meant to keep
    intervals honest must not pull a low-noise estimate's k1 and k2 together.
    ``plane_holds_zero``: "plane" only where the k1 and k2 intervals both hold 0 (the
    spline's: its model bias widens the flatness test beyond its intervals)."""
    one = [None if v is None else np.asarray(v, float)[None] for v in (t, cov, bias, cov_noise)]
    scale = np.array([scale], float)
    return summary_many(one[0], one[1], one[2], scale, intervals, one[3], plane_holds_zero)[0]


def summary_many(t, cov, bias, scale, intervals=True, cov_noise=None, plane_holds_zero=False):
    """``summary`` of every patch of a stack: t (B, 3), cov and cov_noise (B, 3, 3), bias
    (B, 3), scale (B,); a list of dicts.  The linear algebra runs on the whole stack."""
    d2 = classify.flatness_distance(t, cov)
    k1s, k2s = eigen(*np.moveaxis(t, -1, 0))
    m, _, lam = uncertainty.anisotropy_many(t, cov)
    _, h, _ = uncertainty.anisotropy_many(t, cov if cov_noise is None else cov_noise)
    r = np.sqrt(0.5 * (k1s * k1s + k2s * k2s))
    plane = (r <= classify.R_TOL) | (d2 < classify.CHI2_3_999)  # ``classify.is_plane``
    raw = np.hypot(0.5 * (t[:, 0] - t[:, 2]), t[:, 1])
    # no debiasing where the curvature itself is not resolved
    iv = (
        uncertainty.intervals_many(t, cov, m, np.where(plane, raw, h), lam, bias)
        if intervals
        else None
    )
    if iv is not None and plane_holds_zero:
        curved = (r > classify.R_TOL) & _excludes_zero(iv)
        if np.any(plane & curved):
            plane &= ~curved
            iv = uncertainty.intervals_many(t, cov, m, np.where(plane, raw, h), lam, bias)
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
    """Patch ``i``'s fields of ``summary_many`` from its stack's numbers (lists); ``flat`` =
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


def direction1(coef, axes):
    """k1 direction at the centre, world frame."""
    zx, zy, zxx, zxy, zyy = (coef[k] for k in jet_basis.CHANNELS)
    d = principal(zx, zy, zxx, zxy, zyy)["dir1"]
    return np.asarray(d, float) @ axes


def hk_eps(k1_int, k2_int, k1, k2):
    """Zero bands (K, H) for the HK labels from the curvature resolution (0 without intervals)."""
    if k1_int is None:
        return 0.0, 0.0
    h = 0.5 * max(k1_int[1] - k1_int[0], k2_int[1] - k2_int[0])
    return h * max(abs(k1), abs(k2)) + h * h, h
