"""Default EP2 estimator: curvature AT THE PATCH CENTRE from a local jet, the model chosen by data.

For a stack of patches (padded arrays and a row mask), all at once:

1. **Frame** (§5.1.2): mean normal as z, centroid as origin (``patch_frame``);
   lengths divided by the patch size L; origin moved to the middle of the
   contacts' box (the patch centre).
2. **Noise** (§4.9 weights made statistical): positions get 1/(sigma_p sqrt(1+g^2)),
   slopes 1/(sigma_n (1+g^2)).  A sigma not stated is estimated per row type
   from an order-5 jet (REML: residual sum over rows minus leverage).
3. **Osculating frame**: twice, the frame is turned so its z axis is the fitted
   normal at the centre and its origin the fitted surface point there.
4. **Two models of equal size** (3-jets, ``jet_basis``): ``quadric`` (the
   Taylor polynomial) and ``round`` (its quadratic part replaced by the closed
   form that is exact for spheres and cylinders of any radius and axis,
   solved by Gauss-Newton).  ``round`` is chosen when its chi^2 is lower by
   more than ``ROUND_MARGIN``; a quadric height field keeps ``quadric``.
5. **Curvature at the centre**: shape-operator entries t = (a, b, c)
   (``surface_geometry.shape_entries``) with Cov(t) propagated through the
   linear map from the weighted data.  The noise in Cov is never below
   ``FLOOR`` (relative), so noise-free or duplicated data cannot claim
   infinite precision; the other model's difference, weighted by its
   relative likelihood, is kept as a bias vector for the intervals.

Nothing here raises for one bad patch: ``reason`` holds why a patch is refused.
"""

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from tactile.ep2 import batch_lstsq, jet_basis
from tactile.ep2.surface_geometry import shape_entries

ORDER = 3  # jet order of both models (cubic terms: free for symmetric layouts, needed otherwise)
NOISE_ORDER = 5  # jet order for the noise estimate (least model bias), lower for few contacts
FLOOR = 1e-3  # noise floor for Cov: positions / L and normals (rad)
WEIGHT_FLOOR = 1e-6  # relative noise floor for the weights: round-off on exact data sits below
ROUND_MARGIN = 4.0  # chi^2 by which 'round' must beat 'quadric' to be chosen
AMBIGUOUS = 8.0  # chi^2 gaps within this leave the choice open: intervals cover both models
AVERAGE = False
GN_MAX_STEPS = 12  # Gauss-Newton steps for 'round' at most; it stops once every step is tiny
GN_TOL = 1e-12  # ... relative to the coefficients
MAX_REFRAME_DEG = 45.0  # the osculating frame may turn this far from the mean normal, no more
START_Q2 = 0.8  # a start beyond the closed form's rim is scaled to reach this Q2 at most
MODELS = ("quadric", "round")
GEO_LIMIT = 1e3  # slopes and second derivatives (/ L) beyond this are clipped in the weights
NOISE_PASSES = 3  # fixed-point passes for sigma_n (its covariance holds sigma_p too)


@dataclass
class JetFits:
    """Per patch (leading axis B): see the module docstring.  Lengths / L except ``noise``."""

    t: np.ndarray  # (B, 3) shape-operator entries at the centre
    cov: np.ndarray  # (B, 3, 3)
    cov_noise: np.ndarray  # (B, 3, 3) the same without the floor: the estimate's own scatter
    bias: np.ndarray  # (B, 3) model-choice bias vector (0 when the choice is clear)
    dof: np.ndarray  # (B,) degrees of freedom of the noise estimate behind cov (inf: known)
    model: np.ndarray  # (B,) index into MODELS
    chi2: np.ndarray  # (B, len(MODELS)) weighted RSS of each model (inf: round invalid)
    score: np.ndarray  # (B, len(MODELS)) chi2 + 2 rank (+ ROUND_MARGIN for round): lowest wins
    coef: np.ndarray  # (B, p) chosen model's jet coefficients (round: excess added separately)
    scale: np.ndarray  # (B,) L
    origin: np.ndarray  # (B, 3) world coordinates of the final frame's origin
    axes: np.ndarray  # (B, 3, 3) rows: final frame's x, y, z in world coordinates
    noise: np.ndarray  # (B, 2) sigma_pos (input unit), sigma_normal (rad) used for the weights
    stated: tuple  # (pos, normal) stated by the user
    xy: np.ndarray  # (B, n, 2) contacts in the final frame (/ L)
    mask: np.ndarray  # (B, n)
    reason: list  # per patch: None, or why it is refused
    split: tuple  # positions alone, normals alone (``_split_fits``)
    xyz_mean: np.ndarray = None  # (B, n, 3) contacts in the mean-normal frame (/ L)
    mean_axes: np.ndarray = None  # (B, 3, 3) that frame's axes in world coordinates


def fit(points, normals, mask, noise_pos=None, noise_normal=None, max_angle_deg=70.0):
    """Fit every patch of the stack: points, normals (B, n, 3) (unit normals), mask (B, n)."""
    mask = np.asarray(mask, bool)
    reason = [None] * len(mask)
    O, M = _mean_frame(points, normals, mask, reason)
    mean_axes = M
    p = np.einsum("bij,bnj->bni", M, points - O[:, None, :])
    nrm = np.einsum("bij,bnj->bni", M, normals)
    _check_angles(nrm, mask, max_angle_deg, reason)
    L = _size(p, mask, reason)
    centre = 0.5 * (_masked_min(p, mask) + _masked_max(p, mask))
    centre[:, 2] = 0.0
    O = O + np.einsum("bi,bij->bj", centre, M)
    p = (p - centre[:, None, :]) / L[:, None, None]
    xyz_mean = p.copy()
    sig, dof = _noise(p, nrm, mask, noise_pos, noise_normal, L)
    first = _quadric(_refit_rows(p, nrm, mask, sig))
    O, M, p, nrm = _reframe(O, M, L, p, nrm, first.sol.coef)
    quad, rnd = _both(_refit_rows(p, nrm, mask, sig), mask)
    better = np.where(rnd.ok & (rnd.sol.rss < quad.sol.rss), 1, 0)
    coef = np.where(better[:, None] == 1, rnd.sol.coef, quad.sol.coef)
    O, M, p, nrm = _reframe(O, M, L, p, nrm, coef)
    quad, rnd = _both(_refit_rows(p, nrm, mask, sig), mask, rnd.sol.coef)
    better = np.where(rnd.ok & (rnd.sol.rss < quad.sol.rss), 1, 0)
    coef = np.where(better[:, None] == 1, rnd.sol.coef, quad.sol.coef)
    geo = _geometry(_positions(p, mask), coef, better)
    rows = _rows(p, nrm, mask, sig, geo)
    quad, rnd = _both(rows, mask, rnd.sol.coef)
    models = [quad, rnd]  # + quadric 2- and 4-jets by AIC: tried, see _finish
    frame = (L, O, M)
    out = _finish(models, rows, mask, sig, dof, frame, (noise_pos, noise_normal), reason)
    out.bias = _truncation(out, _quadric(_with_order(rows, ORDER + 1)), rows, sig, dof)
    out.split = _split_fits(p, nrm, mask, sig, dof, out)
    out.xyz_mean, out.mean_axes = xyz_mean, mean_axes
    return out


# --- frames ------------------------------------------------------------------------------


def _mean_frame(points, normals, mask, reason):
    """(origin, rotation) per patch as ``patch_frame.frame_from_contacts``, masked."""
    w = mask[..., None]
    count = np.maximum(mask.sum(axis=1), 1)[:, None]
    mean = (normals * w).sum(axis=1) / count
    norm = np.linalg.norm(mean, axis=1)
    for b in np.flatnonzero(~(norm >= 1e-6)):
        reason[b] = "normals inconsistent with one patch: they cancel out (mean normal is zero)"
    ez = mean / np.where(norm >= 1e-6, norm, 1.0)[:, None]
    ez[~(norm >= 1e-6)] = (0.0, 0.0, 1.0)
    ref = np.where(np.abs(ez[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    ex = ref - np.sum(ref * ez, axis=1, keepdims=True) * ez
    ex /= np.linalg.norm(ex, axis=1, keepdims=True)
    ey = np.cross(ez, ex)
    origin = (points * w).sum(axis=1) / count
    return origin, np.stack([ex, ey, ez], axis=1)


def _reframe(O, M, L, p, nrm, coef):
    """Move to the osculating frame of ``coef`` at the centre: origin on the fitted surface,
    z along its normal, x the old x projected (same rule as the mean frame)."""
    gx, gy = coef[:, 1], coef[:, 2]
    ez = np.stack([-gx, -gy, np.ones_like(gx)], axis=1)
    ez /= np.linalg.norm(ez, axis=1, keepdims=True)
    # a fit that tilts the normal at the centre this far from the mean normal is not
    # determined there (one line, say): keep the frame rather than turn it by its guess
    steady = ez[:, 2] < np.cos(np.radians(MAX_REFRAME_DEG))
    ez[steady] = (0.0, 0.0, 1.0)
    coef = np.where(steady[:, None], 0.0, coef)
    ex = np.array([1.0, 0.0, 0.0]) - ez[:, :1] * ez
    ex /= np.linalg.norm(ex, axis=1, keepdims=True)
    R = np.stack([ex, np.cross(ez, ex), ez], axis=1)
    shift = np.zeros_like(O)
    shift[:, 2] = coef[:, 0]
    p = np.einsum("bij,bnj->bni", R, p - shift[:, None, :])
    nrm = np.einsum("bij,bnj->bni", R, nrm)
    O = O + L[:, None] * np.einsum("bi,bij->bj", shift, M)
    return O, R @ M, p, nrm


def _check_angles(nrm, mask, max_angle_deg, reason):
    bad = mask & ~(nrm[..., 2] >= np.cos(np.radians(max_angle_deg)))
    for b in np.flatnonzero(bad.any(axis=1)):
        i = int(np.flatnonzero(bad[b])[0])
        angle = np.degrees(np.arccos(np.clip(nrm[b, i, 2], -1.0, 1.0)))
        reason[b] = reason[b] or (
            f"normals inconsistent with one patch: contact {i} is {angle:.1f} deg from the mean"
            f" normal (limit {max_angle_deg:g} deg; analyse a smaller patch, pass"
            " --max-normal-angle, or check the normals' sign)"
        )


def _size(p, mask, reason):
    ext = _masked_max(p, mask) - _masked_min(p, mask)
    L = np.maximum(ext[:, 0], ext[:, 1])
    for b in np.flatnonzero(~(L > 0)):
        reason[b] = reason[b] or (
            "all contacts at one point: the patch needs contacts spread in two directions"
        )
    return np.where(L > 0, L, 1.0)


def _masked_min(p, mask):
    return np.where(mask[..., None], p, np.inf).min(axis=1)


def _masked_max(p, mask):
    return np.where(mask[..., None], p, -np.inf).max(axis=1)


# --- noise and rows ----------------------------------------------------------------------


@dataclass
class _Rows:
    """One frame's whitened least-squares rows (see ``_rows``)."""

    x: np.ndarray  # (B, n) contact positions
    y: np.ndarray
    b: np.ndarray  # (B, 3n) whitened data
    w: np.ndarray  # (B, 3n) 1 for a used row, 0 for padding or a row type left out
    A: np.ndarray  # (B, 3n, p) whitened jet design
    T: np.ndarray  # (B, n, 3, 3) each contact's whitening of (z, z_x, z_y) (lower triangular)
    P: np.ndarray  # (B, n, 3, 3) its covariance per unit sigma_p^2 (J J^T)
    N: np.ndarray  # (B, n, 3, 3) ... per unit sigma_n^2

    def whiten(self, v):
        """Whiten stacked rows (B, 3n) or (B, 3n, k) (positions, x-slopes, y-slopes)."""
        return _whiten(v, self.T)


def _whiten(v, T):
    """Each contact's 3 rows times its lower-triangular 3 x 3 whitening (``_inverse_cholesky``;
    six multiply-adds per row: a batched 3 x 3 product is slower through einsum or matmul
    at this size)."""
    B, n = T.shape[:2]
    blocks = v.reshape(B, 3, n, -1)
    Tt = T[..., None]  # (B, n, 3, 3, 1)
    out = np.empty_like(blocks)
    out[:, 0] = Tt[:, :, 0, 0] * blocks[:, 0]
    out[:, 1] = Tt[:, :, 1, 0] * blocks[:, 0] + Tt[:, :, 1, 1] * blocks[:, 1]
    out[:, 2] = Tt[:, :, 2, 0] * blocks[:, 0] + Tt[:, :, 2, 1] * blocks[:, 1]
    out[:, 2] += Tt[:, :, 2, 2] * blocks[:, 2]
    return out.reshape(v.shape)


def _rows(p, nrm, mask, sig, geo=None, order=None, part="all"):
    """Rows in the current frame, each contact's (z, z_x, z_y) whitened by its covariance.

    Slopes z_x = -nx/nz, z_y = -ny/nz (§4.5.1).  Errors to first order (errors in
    variables, "effective variance"): a position error e (3-D, sigma_p) moves z by
    e_z - g.e_xy and, because the slope is read where the contact is not, the slopes by
    -h e_xy (h the Hessian there); an angular error of the normal (sigma_n) moves the
    slopes with covariance sigma_n^2 (1+|g|^2)(I + g g^T) (checked by simulation in the
    tests).  So Cov = sigma_p^2 J J^T + sigma_n^2 [[0, 0], [0, (1+|g|^2)(I + g g^T)]] with
    J = [[-g^T, 1], [-h, 0]], and the rows are whitened by L^-1, L L^T = Cov.  ``geo`` = (g, h)
    (B, n, 2) and (B, n, 3) from a fit: taken from the observed slopes instead, they favour
    the rows whose noise flattened them and bias the curvature (and h = 0 without a fit).
    ``part`` "pos" or "slopes" keeps one row type (its own marginal covariance), for the
    noise estimate and the positions-versus-normals check.
    """
    nz = np.where(mask, nrm[..., 2], 1.0)
    sx, sy = -nrm[..., 0] / nz * mask, -nrm[..., 1] / nz * mask
    if geo is None:
        g, h = np.stack([sx, sy], -1), np.zeros(mask.shape + (3,))
    else:
        g, h = geo
    T, P, N = _whitening(g, h, sig, part)
    x, y = (np.where(mask, p[..., k], 0.0) for k in (0, 1))
    b = np.concatenate([np.where(mask, p[..., 2], 0.0), sx, sy], axis=1)
    keep = {"all": (1, 1, 1), "pos": (1, 0, 0), "slopes": (0, 1, 1)}[part]
    w = np.concatenate([mask * k for k in keep], axis=1).astype(float)
    A = jet_basis.design(x, y, ORDER if order is None else order)
    return _Rows(x, y, _whiten(b, T), w, _whiten(A, T), T, P, N)


def _whitening(g, h, sig, part):
    """(L^-1 with L L^T = Cov, J J^T, N) (B, n, 3, 3) of each contact's (z, z_x, z_y)
    residual: Cov = sigma_p^2 J J^T + sigma_n^2 N (``_rows``); ``part`` keeps one row type's
    block."""
    g = np.clip(np.nan_to_num(g), -GEO_LIMIT, GEO_LIMIT)  # a degenerate fit's wild geometry
    h = np.clip(np.nan_to_num(h), -GEO_LIMIT, GEO_LIMIT)
    gx, gy = g[..., 0], g[..., 1]
    g2 = gx * gx + gy * gy
    zero, one = np.zeros_like(gx), np.ones_like(gx)
    J = np.stack(
        [
            np.stack([-gx, -gy, one], -1),
            np.stack([-h[..., 0], -h[..., 1], zero], -1),
            np.stack([-h[..., 1], -h[..., 2], zero], -1),
        ],
        -2,
    )
    P = J @ np.swapaxes(J, -1, -2)
    N = np.zeros_like(P)
    N[..., 1:, 1:] = (1.0 + g2)[..., None, None] * (np.eye(2) + g[..., :, None] * g[..., None, :])
    keep = {"all": [0, 1, 2], "pos": [0], "slopes": [1, 2]}[part]
    drop = [k for k in range(3) if k not in keep]
    for M in (P, N):
        M[..., drop, :] = 0.0
        M[..., :, drop] = 0.0
    cov = sig[:, 0, None, None, None] ** 2 * P + sig[:, 1, None, None, None] ** 2 * N
    cov[..., drop, drop] = 1.0  # placeholders, removed from T below
    T = _inverse_cholesky(cov)
    T[..., drop, :] = 0.0
    return T, P, N


def _inverse_cholesky(c):
    """L^-1 (lower triangular) with L L^T = c, for every 3 x 3 of the stack, in closed form
    (LAPACK's one call per contact cost a fifth of the fit).  Any whitening W with
    W^T W = c^-1 gives the same fit, covariance and chi^2: they differ by a rotation of
    each contact's three rows."""
    tiny = 1e-300  # a pivot never below this (c is positive definite: sigmas are floored)
    l00 = np.sqrt(np.maximum(c[..., 0, 0], tiny))
    l10, l20 = c[..., 1, 0] / l00, c[..., 2, 0] / l00
    l11 = np.sqrt(np.maximum(c[..., 1, 1] - l10 * l10, tiny))
    l21 = (c[..., 2, 1] - l20 * l10) / l11
    l22 = np.sqrt(np.maximum(c[..., 2, 2] - l20 * l20 - l21 * l21, tiny))
    T = np.zeros_like(c)
    T[..., 0, 0], T[..., 1, 1], T[..., 2, 2] = 1.0 / l00, 1.0 / l11, 1.0 / l22
    T[..., 1, 0] = -l10 * T[..., 0, 0] * T[..., 1, 1]
    T[..., 2, 1] = -l21 * T[..., 1, 1] * T[..., 2, 2]
    T[..., 2, 0] = -(l20 * T[..., 0, 0] + l21 * T[..., 1, 0]) * T[..., 2, 2]
    return T


def _positions(p, mask):
    """The contacts' x, y as ``_Rows`` hold them (padding at 0), for ``_geometry``."""
    x, y = (np.where(mask, p[..., k], 0.0) for k in (0, 1))
    return SimpleNamespace(x=x, y=y)


def _with_order(rows, order):
    """``rows`` with the jet design of another order (same data, weights and whitening)."""
    A = _whiten(jet_basis.design(rows.x, rows.y, order), rows.T)
    return _Rows(rows.x, rows.y, rows.b, rows.w, A, rows.T, rows.P, rows.N)


def _geometry(rows, coef, model=None):
    """(g (B, n, 2), h (B, n, 3)): slopes and second derivatives of a fit at the contacts
    (``rows`` or ``_positions``: their x, y); ``model`` (B,) 1 where ``coef`` is the round
    model (its closed-form part added)."""
    x, y = rows.x, rows.y
    order = jet_basis.order_of(coef.shape[-1])
    d = jet_basis.design(x, y, order, ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2)))
    v = np.einsum("bmp,bp->bm", d, coef).reshape(len(coef), 5, -1)
    if model is not None and np.any(model == 1):
        H = jet_basis.hessian(coef)
        _, ex, ey = jet_basis.round_excess(x, y, H)
        exx, exy, eyy = jet_basis.round_second(x, y, H)
        extra = np.stack([ex, ey, exx, exy, eyy], axis=1)
        v = v + np.where(model[:, None, None] == 1, extra, 0.0)
    return np.moveaxis(v[:, :2], 1, -1), np.moveaxis(v[:, 2:], 1, -1)


def _refit_rows(p, nrm, mask, sig):
    """Rows of the current frame whitened with the geometry of a first quadric fit."""
    rows = _rows(p, nrm, mask, sig)
    return _rows(p, nrm, mask, sig, _geometry(rows, _quadric(rows).sol.coef))


def _noise(p, nrm, mask, noise_pos, noise_normal, L):
    """(sigma_p / L, sigma_n) and their degrees of freedom (inf: stated) per patch.

    A sigma not stated is estimated by REML from its own rows: positions from a jet of
    positions, slopes from a jet of slopes (``_noise_order``; geometry from a first fit).
    Estimated jointly, a disagreement between positions and normals would inflate both
    and hide.  The slopes' covariance holds sigma_p too (``_rows``), so sigma_n is found
    by a few fixed-point passes on the slopes' chi^2 per spare row.
    """
    B = len(mask)
    sig, dof = np.ones((B, 2)), np.full((B, 2), np.inf)
    if noise_pos is not None:
        sig[:, 0] = max(float(noise_pos), 0.0) / L
    if noise_normal is not None:
        sig[:, 1] = max(float(noise_normal), 0.0)
    sig = np.maximum(sig, WEIGHT_FLOOR)
    if noise_pos is not None and noise_normal is not None:
        return sig, dof
    rows = _rows(p, nrm, mask, sig)
    geo = _geometry(rows, _quadric(rows).sol.coef)
    n = mask.sum(axis=1)
    if noise_pos is None:
        sig[:, 0], dof[:, 0] = _reml(p, nrm, mask, sig, geo, "pos", n)
    if noise_normal is None:
        ratio = _slope_share(geo, mask)
        for _ in range(NOISE_PASSES):
            scale, dof[:, 1] = _reml(p, nrm, mask, sig, geo, "slopes", 2 * n)
            # chi^2 per spare row = scale^2: the slopes' covariance sigma_p^2 h h^T +
            # sigma_n^2 S is scale^2 times too small; sigma_n takes all of the change
            var = scale**2 * sig[:, 1] ** 2 + (scale**2 - 1.0) * sig[:, 0] ** 2 * ratio
            sig[:, 1] = np.sqrt(np.maximum(var, WEIGHT_FLOOR**2))
    return np.maximum(sig, WEIGHT_FLOOR), dof


def _slope_share(geo, mask):
    """Mean over the contacts of tr(h h^T) / tr(S): the slopes' variance from position noise
    per unit sigma_p^2 over the one from normal noise per unit sigma_n^2 (``_rows``)."""
    g, h = geo
    g2 = np.sum(g * g, axis=-1)
    tr_s = (1.0 + g2) * (2.0 + g2)
    tr_h = h[..., 0] ** 2 + 2 * h[..., 1] ** 2 + h[..., 2] ** 2
    return np.sum(np.where(mask, tr_h / tr_s, 0.0), axis=1) / np.maximum(mask.sum(axis=1), 1)


def _reml(p, nrm, mask, sig, geo, part, count):
    """(sqrt(chi^2 / spare rows), spare rows) of one row type's own jet fit.  For positions
    the rows are whitened with sigma_p = 1, so the first value IS sigma_p / L."""
    trial = sig.copy()
    if part == "pos":
        trial[:, 0] = 1.0
    rows = _rows(p, nrm, mask, trial, geo, NOISE_ORDER, part)
    degree = np.array([i + j for i, j in jet_basis.monomials(NOISE_ORDER)])
    order = _noise_order(count)
    sol = batch_lstsq.solve(rows.A * (degree <= order[:, None])[:, None, :], rows.b, rows.w)
    spare = count - sol.leverage.sum(axis=1)
    ok = spare >= 1.0  # no spare rows: the noise is unknown, taken as large (sigma 1 = L)
    value = np.where(ok, np.sqrt(sol.rss / np.where(ok, spare, 1.0)), 1.0)
    return value, np.where(ok, spare, 1.0)


def _noise_order(rows):
    """Highest jet order (<= NOISE_ORDER, >= 2) leaving at least half of ``rows`` spare."""
    order = np.full(np.shape(rows), 2)
    for q in range(3, NOISE_ORDER + 1):
        order = np.where(jet_basis.n_coef(q) <= rows / 2, q, order)
    return order


# --- the two models --------------------------------------------------------------------


@dataclass
class _Model:
    sol: batch_lstsq.Solution
    jac: np.ndarray  # (B, 3n, p) design (round: linearised at the solution)
    ok: np.ndarray  # (B,) usable (round: every contact inside the closed form's rim)


def _both(rows, mask, start=None):
    """The quadric and the round model on the same rows (round from ``start`` or the quadric)."""
    quad = _quadric(rows)
    return quad, _round(rows, mask, quad.sol.coef if start is None else start)


def _quadric(rows):
    return _Model(batch_lstsq.solve(rows.A, rows.b, rows.w), rows.A, np.ones(len(rows.b), bool))


def _round(rows, mask, coef):
    """Gauss-Newton on the 'round' model from ``coef``, per patch until every step is below
    ``GN_TOL`` (at most ``GN_MAX_STEPS``): a patch that has converged leaves the batch, so it
    gets the iterations it would get alone; its last solve only linearises at its final
    iterate.  The iterates of a patch its contacts do not determine (two points, say) may
    overflow: ``batch_lstsq`` gives it NaN, ``ok`` is False, and it is refused later."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _gauss_newton(rows, mask, coef)


def _gauss_newton(rows, mask, coef):
    x, y, b, w, A = rows.x, rows.y, rows.b, rows.w, rows.A
    cols = list(jet_basis.HESSIAN)
    coef = _inside_rim(coef, x, y, mask, START_Q2)
    todo = np.arange(len(coef))
    parts, J_all, r_all = [], np.empty_like(A), np.empty_like(b)
    for step in range(GN_MAX_STEPS + 1):
        xs, ys, c, T = x[todo], y[todo], coef[todo], rows.T[todo]
        H = jet_basis.hessian(c)
        J = A[todo]
        J[..., cols] += _whiten(jet_basis.round_jacobian(xs, ys, H), T)
        r = (
            b[todo]
            - np.einsum("bmp,bp->bm", A[todo], c)
            - _whiten(jet_basis.round_rows(xs, ys, H), T)
        )
        sol = batch_lstsq.solve(J, r, w[todo])
        tiny = np.abs(sol.coef) <= GN_TOL * np.maximum(np.abs(c), 1.0)
        done = np.all(tiny | ~np.isfinite(sol.coef), axis=1) | (step == GN_MAX_STEPS)
        parts.append((todo[done], batch_lstsq.take(sol, done)))
        J_all[todo[done]], r_all[todo[done]] = J[done], r[done]
        go = ~done
        coef[todo[go]] = _step(c[go], sol.coef[go], xs[go], ys[go], mask[todo[go]])
        todo = todo[go]
        if not todo.size:
            break
    sol = batch_lstsq.merge(parts, len(coef))
    # the last solve only linearises at the iterate: keep the iterate and its own residual
    sol.coef, sol.residual = coef, r_all * w
    sol.rss = np.einsum("bm,bm->b", sol.residual, sol.residual)
    ok = jet_basis.round_valid(x, y, jet_basis.hessian(coef), mask) & np.all(np.isfinite(coef), 1)
    return _Model(sol, J_all, ok)


def _inside_rim(coef, x, y, mask, limit):
    """Scale the Hessian of a start whose closed form passes the rim (a quadric fit of a
    tight cylinder overestimates its curvature) so the contacts reach Q2 = ``limit``."""
    q = jet_basis.max_q2(x, y, jet_basis.hessian(coef), mask)
    beyond = ~(q < jet_basis.ROUND_MAX_Q2)
    shrink = np.where(beyond, np.sqrt(limit / np.maximum(q, 1e-300)), 1.0)
    out = coef.copy()
    out[:, list(jet_basis.HESSIAN)] *= shrink[:, None]
    return out


def _step(coef, step, x, y, mask):
    """coef + step, the step halved (up to 8 times) where it would cross the rim."""
    scale = np.ones(len(coef))
    for _ in range(8):
        trial = coef + scale[:, None] * step
        bad = ~(jet_basis.max_q2(x, y, jet_basis.hessian(trial), mask) < jet_basis.ROUND_MAX_Q2)
        if not bad.any():
            break
        scale = np.where(bad, 0.5 * scale, scale)
    return coef + scale[:, None] * step


# --- curvature at the centre -------------------------------------------------------------


def _tensor(coef, pinv):
    """t (B, 3) at the origin and dt / d(weighted data) (B, 3, m), by complex step."""
    ch = coef[:, list(jet_basis.CHANNELS)]
    steps = ch[:, None, :] + 1j * 1e-20 * np.eye(5)[None]  # (B, 5 copies, 5 channels)
    # a patch its contacts do not determine (one line) can carry astronomically large
    # coefficients, whose squares leave the float range: ``centre_result.determination``
    # refuses it from its spread and covariance; the other patches of the batch are exact
    with np.errstate(over="ignore", invalid="ignore"):
        a, b, c = shape_entries(*np.moveaxis(steps, -1, 0))
    t = np.stack([a[:, 0].real, b[:, 0].real, c[:, 0].real], axis=1)
    J = np.stack([a.imag, b.imag, c.imag], axis=1) / 1e-20  # (B, 3, 5)
    return t, J @ pinv[:, list(jet_basis.CHANNELS), :]


def _cov(G, rows, rss, rank, sig, dof):
    """Cov = s^2 sum_c G_c T_c Sigma_c T_c^T G_c^T over the contacts c (G: (B, q, 3n), a linear
    map of the whitened data), where Sigma_c is the contact's covariance with each sigma
    lifted to at least ``FLOOR``, and s^2 = max(chi^2/dof, 1); and the Satterthwaite degrees
    of freedom of that noise estimate."""
    B, q, m3 = G.shape
    n = m3 // 3
    Gc = G.reshape(B, q, 3, n)
    lifted = np.maximum(sig, FLOOR)
    unit = []  # each row type's part for a unit sigma
    for M in (rows.P, rows.N):
        K = rows.T @ M @ np.swapaxes(rows.T, -1, -2)  # (B, n, 3, 3)
        unit.append(np.einsum("zian,znac,zjcn->zij", Gc, K, Gc))
    parts = [lifted[:, k, None, None] ** 2 * unit[k] for k in range(2)]
    used = rows.w.sum(axis=1)
    s2 = np.maximum(rss / np.maximum(used - rank, 1), 1.0)
    with np.errstate(invalid="ignore"):  # inf x 0 on a failed round fit, which is not used
        cov = s2[:, None, None] * (parts[0] + parts[1])
        # the noise as estimated, no floor: what the estimate's own scatter is (debiasing)
        raw = s2[:, None, None] * sum(sig[:, k, None, None] ** 2 * unit[k] for k in range(2))
    share = np.stack([np.trace(q_, axis1=1, axis2=2) for q_ in parts], axis=1)
    with np.errstate(invalid="ignore"):  # inf / inf on a failed round fit, which is not used
        share = share / np.maximum(share.sum(axis=1, keepdims=True), 1e-300)
    share = np.nan_to_num(share, nan=0.5)
    known = np.where(lifted > sig, np.inf, dof)  # at the floor, the noise is taken as known
    denom = np.sum(share**2 / known, axis=1)
    nu = np.where(denom > 0, 1.0 / np.where(denom > 0, denom, 1.0), np.inf)
    return cov, nu, raw


def _finish(models, rows, mask, sig, dof, frame, stated, reason):
    """Choose between ``models`` (``MODELS``) by chi^2 + 2 x rank (round must beat the
    quadric by ``ROUND_MARGIN`` more); the runner-up's estimate, weighted by its relative
    likelihood (1 within ``AMBIGUOUS``), is the bias vector for the intervals.

    Tried on the first holdout and declined: adding quadric 2- and 4-jets to the choice
    (by AIC: better on tilted quadric height fields, whose 3-jet keeps a truncation bias,
    but a 4-jet runner-up's noisy estimate widened small patches into refusals), and a
    focused criterion (the tensor's MSE estimated against the 4-jet: its bias estimate is
    too noisy; worse on cylinders)."""
    L, O, M = frame
    chi2 = np.stack([np.where(m.ok, m.sol.rss, np.inf) for m in models], axis=1)
    rank = np.stack([m.sol.rank for m in models], axis=1).astype(float)
    score = chi2 + 2.0 * rank
    score[:, 1] += ROUND_MARGIN
    score = np.nan_to_num(score, nan=np.inf)
    order = np.argsort(score, axis=1, kind="stable")
    model, runner = order[:, 0], order[:, 1]
    out = []
    for m in models:
        t, G = _tensor(m.sol.coef, m.sol.pinv)
        out.append((t, *_cov(G, rows, m.sol.rss, m.sol.rank, sig, dof)))
    t_all, cov_all, nu_all, raw_all = (np.stack([o[k] for o in out], axis=1) for k in range(4))

    def take(a, idx):
        return a[np.arange(len(idx)), idx]

    t, cov, nu, cov_noise = (take(a, model) for a in (t_all, cov_all, nu_all, raw_all))
    other = take(t_all, runner)
    gap = take(score, runner) - take(score, model)  # >= 0
    p_other = np.exp(-0.5 * np.minimum(np.nan_to_num(gap, nan=np.inf), 1400.0))
    p_other = np.where(gap <= AMBIGUOUS, 1.0, p_other)
    bias = np.sqrt(p_other)[:, None] * np.where(np.isfinite(other), other - t, 0.0)
    width = max(m.sol.coef.shape[1] for m in models)
    padded = np.stack([_pad(m.sol.coef, width) for m in models], axis=1)
    coef = take(padded, model)
    return JetFits(
        t=t,
        cov=cov,
        cov_noise=cov_noise,
        bias=bias,
        dof=nu,
        model=model,
        chi2=chi2,
        score=score,
        coef=coef,
        scale=L,
        origin=O,
        axes=M,
        noise=np.stack([sig[:, 0] * L, sig[:, 1]], axis=1),
        stated=tuple(v is not None for v in stated),
        xy=np.stack([rows.x, rows.y], axis=-1),
        mask=mask,
        reason=reason,
        split=(),
    )


def _truncation(fits, quartic, rows, sig, dof):
    """The bias vector for the intervals: the model-choice one, or the 3-jet's truncation
    as the 4-jet sees it, whichever is larger.  The difference d = t_4 - t is shrunk by its
    own noise, max(0, 1 - 3 v / |d|^2) with v = tr Cov(t_4) - tr Cov(t) (under no bias
    |d|^2 ~ v chi^2_3 / 3: kept in ~3 % of noise-only draws), so it only widens where the
    4-jet sees a curvature the 3-jet misses (strongly curved, tilted height fields).
    Nothing where the layout does not determine the 4-jet, nor for the round model (the
    closed form holds every even order of a sphere or cylinder, which a 4-jet truncates)."""
    t4, G = _tensor(quartic.sol.coef, quartic.sol.pinv)
    raw4 = _cov(G, rows, quartic.sol.rss, quartic.sol.rank, sig, dof)[2]
    d = np.where(np.isfinite(t4), t4 - fits.t, 0.0)
    v = np.maximum(np.trace(raw4, axis1=1, axis2=2) - np.trace(fits.cov_noise, axis1=1, axis2=2), 0)
    size = np.sum(d * d, axis=1)
    keep = np.maximum(1.0 - 3.0 * v / np.where(size > 0, size, np.inf), 0.0)
    full = quartic.sol.rank == quartic.sol.coef.shape[1]
    keep = np.where(full & (fits.model == 0), keep, 0.0)  # round: exact where 4-jets are not
    trunc = keep[:, None] * d
    larger = np.sum(trunc * trunc, axis=1) > np.sum(fits.bias * fits.bias, axis=1)
    return np.where(larger[:, None], trunc, fits.bias)


def _pad(coef, width):
    """Jet coefficients padded with zeros to ``width`` (graded order: the same polynomial)."""
    return np.pad(coef, ((0, 0), (0, width - coef.shape[1])))


def _split_fits(p, nrm, mask, sig, dof, fits):
    """Each row type fitted alone with the joint fit's model (round: Gauss-Newton from the
    joint solution; nothing held from it, which may be nonsense when they disagree): two
    independent estimates of the five derivatives (z_x, z_y, z_xx, z_xy, z_yy) at the
    centre, which agree within their covariances when positions and normals describe one
    surface.  Returns ((d, cov, seen) positions, (d, cov, seen) normals), ``seen`` =
    (blind (B, p, 5), scale (B, 5)) of ``batch_lstsq`` for the five derivatives: what that
    row type does not determine (positions on two lines do not give z_xx; nothing on one
    line gives the curvature across it)."""
    geo = _geometry(_positions(p, mask), fits.coef, fits.model)
    out = []
    for part in ("pos", "slopes"):
        first = _rows(p, nrm, mask, sig, geo, ORDER, part)
        own = _geometry(first, _quadric(first).sol.coef)  # the joint fit may be nonsense
        rows = _rows(p, nrm, mask, sig, own, ORDER, part)
        model = _quadric(rows)
        start = fits.coef[:, : model.sol.coef.shape[1]]
        rnd = _round(rows, mask, np.where((fits.model == 1)[:, None], start, model.sol.coef))
        pick = ((fits.model == 1) & rnd.ok)[:, None]  # the joint fit's model, refitted
        # misfit of this row type under its own better family: model error, not disagreement
        best = np.minimum(model.sol.rss, np.where(rnd.ok, rnd.sol.rss, np.inf))
        own_s2 = np.maximum(best / np.maximum(rows.w.sum(axis=1) - model.sol.rank, 1), 1.0)
        for key in ("coef", "Q", "P", "rss", "blind", "scale", "rank"):
            a, b = getattr(rnd.sol, key), getattr(model.sol, key)
            shape = pick.reshape(pick.shape[:1] + (1,) * (np.ndim(a) - 1))
            setattr(model.sol, key, np.where(shape, a, b))
        sol = model.sol
        ch = list(jet_basis.CHANNELS)
        # the noise, times the misfit of the row type's own better family only: a joint
        # family that misfits one row type (mirrored normals, say) must not widen its way
        # out of the comparison, but a surface no 3-jet follows is not a disagreement
        cov, _, _ = _cov(sol.pinv[:, ch, :], rows, np.zeros_like(sol.rss), sol.rank, sig, dof)
        cov = cov * own_s2[:, None, None]
        out.append((sol.coef[:, ch], cov, (sol.blind[:, :, ch], sol.scale[:, ch])))
    return tuple(out)
