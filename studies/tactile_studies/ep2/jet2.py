"""A batched numpy 2-jet with normals: the plain peer every EP2 estimator is scored against.

Per patch, in the mean-normal patch frame (z = normalised mean unit normal, x = world x
projected on the tangent plane, or world y where x is nearly normal, origin the centroid:
the rule of ``tactile.ep2.geometry``, §5.1.2), lengths divided by L (the larger side
of the contacts' box) and centred on the box's middle, fit

    z = c + g . x + x^T A x / 2

to the positions (rows [1, x, y, x^2/2, x y, y^2/2]) and the slopes dz/dx = -nx/nz,
dz/dy = -ny/nz (§4.5.1; rows [0, 1, 0, x, y, 0] and [0, 0, 1, 0, x, y]), weighted
1/(sigma_p sqrt(1 + |g_i|^2)) and 1/(sigma_n (1 + |g_i|^2)) as the default's rows (g_i the
measured slope).  The sigmas are the stated noise (floored at ``FLOOR`` of L and rad) or,
unstated, one REML pass: a unit-weight fit, then each row type's weighted residual sum over
its rows less their leverage.  Curvature at the centre (x = 0) from (g, A) through the first
and second fundamental forms (§2.2), S = (2/pi) atan2(k1 + k2, k1 - k2) (§2.4).

Cov(coef) = s^2 (A_w^T A_w)^-1 from the QR of the weighted design, s^2 = chi^2/dof
(unstated) or max(chi^2/dof, 1) (stated, or an estimate at its floor: misfit beyond that
noise widens it);
95 % intervals of S, k1, k2 by the delta method (central differences of the map from the
five derivatives).  The label is the S band holding the whole S interval, ``plane`` when
both k intervals hold 0, else ``uncertain``.  Patches of one size are stacked and solved
together (``numpy.linalg.qr`` on the stack).  No outlier handling and no refusal but a
rank-deficient design (``DataError``): a normal far from the mean gives a steep slope
(nz kept at least ``MIN_NZ`` in size, its sign kept) whose row the (1 + |g|^2) factor
down-weights; a reversed normal gives its original slope back.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2.geometry import PatchFrame
from tactile.errors import DataError

FLOOR = 1e-6  # stated sigmas below this (of L, rad) are taken as this: a weight needs one
MIN_NZ = 1e-6  # |nz| of a normal in the patch frame, at least (slopes stay finite)
REML_FLOOR = 1e-12  # an estimated sigma never below this (round-off of exact data)
Z95 = 1.959963984540054
BANDS = {
    "sphere": (0.75, 1.0),
    "cylinder": (0.25, 0.75),
    "saddle": (-0.25, 0.25),
    "concave_cylinder": (-0.75, -0.25),
    "concave_sphere": (-1.0, -0.75),
}


@dataclass
class Jet2Result:
    """What the 2-jet reports, with the fields the scorer reads (as ``PatchResult``)."""

    S: float
    k1: float
    k2: float
    S_interval: tuple
    k1_interval: tuple
    k2_interval: tuple
    shape: str
    confidence: float
    frame: PatchFrame
    box: tuple  # contacts' box in the frame, / scale
    scale: float
    centre: np.ndarray  # the fitted surface point under the box's middle (world)
    noise_pos: float
    noise_normal: float
    warnings: list = field(default_factory=list)


def curvatures(c):
    """(k1, k2), k1 >= k2, from (..., 5) derivatives (zx, zy, zxx, zxy, zyy) of a height
    field at a point (convex toward +z positive, §2.2); cancellation-free at umbilics."""
    p, q, hxx, hxy, hyy = np.moveaxis(c, -1, 0)
    E, F, G = 1.0 + p * p, p * q, 1.0 + q * q
    w3 = (E * G - F * F) ** 1.5
    mean = -(G * hxx - 2 * F * hxy + E * hyy) / (2 * w3)
    n = (E * hyy - G * hxx) ** 2 + 4 * (E * hxy - F * hxx) * (G * hxy - F * hyy)
    root = np.sqrt(np.maximum(n, 0.0)) / (2 * w3)
    return mean + root, mean - root


def _quantities(c):
    """(..., 3): k1, k2, S of derivatives (..., 5)."""
    k1, k2 = curvatures(c)
    return np.stack([k1, k2, 2 / np.pi * np.arctan2(k1 + k2, k1 - k2)], axis=-1)


def frames(P, N):
    """(origin (B, 3), rot (B, 3, 3)) of stacked contacts, as ``frame_from_contacts``."""
    ez = N.mean(axis=1)
    ez = ez / np.linalg.norm(ez, axis=-1, keepdims=True)
    ref = np.where(np.abs(ez[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    ex = ref - np.sum(ref * ez, axis=-1, keepdims=True) * ez
    ex /= np.linalg.norm(ex, axis=-1, keepdims=True)
    return P.mean(axis=1), np.stack([ex, np.cross(ez, ex), ez], axis=1)


def _design(x, y, one, zero):
    pos = np.stack([one, x, y, 0.5 * x * x, x * y, 0.5 * y * y], axis=-1)
    sx = np.stack([zero, one, zero, x, y, zero], axis=-1)
    sy = np.stack([zero, zero, one, zero, x, y], axis=-1)
    return np.concatenate([pos, sx, sy], axis=1)


def _weighted_solve(A, b, w):
    """Stacked weighted least squares: (coef, R, residual, rank ok)."""
    Aw, bw = A * w[..., None], b * w
    Q, R = np.linalg.qr(Aw)
    d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    ok = d.min(axis=-1) > 1e-10 * d.max(axis=-1)
    R_safe = R + np.where(ok, 0.0, 1.0)[:, None, None] * np.eye(R.shape[-1])
    coef = np.linalg.solve(R_safe, np.einsum("bri,br->bi", Q, bw)[..., None])[..., 0]
    return coef, R_safe, b - np.einsum("bri,bi->br", A, coef), ok, Q


def fit_group(P, N, sig_p, sig_n, fisher=False, positions_only=False):
    """The 2-jet of a stack of patches of one size (B, n, 3); ``sig_p`` (data unit) and
    ``sig_n`` (rad) per patch, NaN where not stated.  ``fisher``: Cov without the
    chi^2/dof factor (the information the rows carry at that noise).  Returns a dict of
    arrays: coef (B, 6, L units), cov (B, 6, 6), q (B, 3) = k1, k2 (1/data unit), S,
    qcov (B, 3, 3), frame origin/rot, box, L, centre, sigmas, ok, why."""
    B, n, _ = P.shape
    N = N / np.linalg.norm(N, axis=-1, keepdims=True)
    origin, rot = frames(P, N)
    p = np.einsum("bij,bnj->bni", rot, P - origin[:, None])
    nl = np.einsum("bij,bnj->bni", rot, N)
    nz = np.where(nl[..., 2] < 0, -1.0, 1.0) * np.maximum(np.abs(nl[..., 2]), MIN_NZ)
    sx, sy = -nl[..., 0] / nz, -nl[..., 1] / nz
    lo, hi = p[..., :2].min(axis=1), p[..., :2].max(axis=1)
    L = np.max(hi - lo, axis=-1)
    L = np.where(L > 0, L, 1.0)
    mid = 0.5 * (lo + hi)
    x, y = ((p[..., k] - mid[:, k : k + 1]) / L[:, None] for k in (0, 1))
    z = p[..., 2] / L[:, None]
    A = _design(x, y, np.ones_like(x), np.zeros_like(x))
    b = np.concatenate([z, sx, sy], axis=1)
    g2 = 1.0 + sx * sx + sy * sy
    fp, fn = np.sqrt(g2), g2  # d(height)/d(position noise), d(slope)/d(angle)
    if positions_only:  # the classic quadric jet: heights alone (slopes weighted 0)
        fn = np.full_like(fn, np.inf)
    stated = np.isfinite(sig_p) & np.isfinite(sig_n)
    sp = np.where(stated, np.maximum(np.nan_to_num(sig_p) / L, FLOOR), 1.0)
    sn = np.where(stated, np.maximum(np.nan_to_num(sig_n), FLOOR), 1.0)
    if not stated.all():  # one REML pass from unit weights, per row type
        w0 = np.concatenate([1 / fp, 1 / fn, 1 / fn], axis=1)
        _, R0, r0, _, Q0 = _weighted_solve(A, b, w0)
        lev = np.sum(Q0 * Q0, axis=-1)  # hat diagonal of the weighted design
        rw = (r0 * w0) ** 2
        rss_p, lev_p = rw[:, :n].sum(-1), lev[:, :n].sum(-1)
        rss_n, lev_n = rw[:, n:].sum(-1), lev[:, n:].sum(-1)
        est_p = np.sqrt(rss_p / np.maximum(n - lev_p, 1.0))
        est_n = np.sqrt(rss_n / np.maximum(2 * n - lev_n, 1.0)) if not positions_only else 1.0
        floored = ~stated & ((est_p < REML_FLOOR) | (est_n < REML_FLOOR))
        sp = np.where(stated, sp, np.maximum(est_p, REML_FLOOR))
        sn = np.where(stated, sn, np.maximum(est_n, REML_FLOOR))
        stated = stated | floored  # a floored estimate, like a stated sigma, widens only
    w = np.concatenate([1 / (sp[:, None] * fp), 1 / (sn[:, None] * fn), 1 / (sn[:, None] * fn)], 1)
    coef, R, r, ok, _ = _weighted_solve(A, b, w)
    chi2 = np.sum((r * w) ** 2, axis=-1)
    dof = (n if positions_only else 3 * n) - 6
    s2 = chi2 / dof if dof > 0 else np.full(B, np.inf)
    s2 = np.ones(B) if fisher else np.where(stated, np.maximum(s2, 1.0), s2)
    Rinv = np.linalg.inv(R)
    cov = s2[:, None, None] * Rinv @ np.swapaxes(Rinv, -1, -2)
    q, qcov = _delta(coef[:, 1:], cov[:, 1:, 1:])
    q[:, :2] /= L[:, None]
    qcov[:, :2, :] /= L[:, None, None]
    qcov[:, :, :2] /= L[:, None, None]
    why = np.where(ok, "", "the 2-jet's design is rank deficient")
    centre = origin + np.einsum("bi,bij->bj", np.column_stack([mid, coef[:, 0] * L]), rot)
    box = np.column_stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1]]) / L[:, None]
    return dict(
        coef=coef, cov=cov, q=q, qcov=qcov, origin=origin, rot=rot, box=box, L=L,
        centre=centre, sig_p=sp * L, sig_n=sn, ok=ok, why=why,
    )  # fmt: skip


def _delta(d, cov5, h=1e-6):
    """(quantities (B, 3), their delta-method covariance (B, 3, 3)) of derivatives d (B, 5)."""
    q = _quantities(d)
    step = h * np.maximum(1.0, np.abs(d))
    J = np.empty(q.shape + (5,))
    for j in range(5):
        e = np.zeros(5)
        e[j] = 1.0
        up, dn = _quantities(d + step[:, j : j + 1] * e), _quantities(d - step[:, j : j + 1] * e)
        J[..., j] = (up - dn) / (2 * step[:, j : j + 1])
    return q, J @ cov5 @ np.swapaxes(J, -1, -2)


def label(S, S_iv, k1_iv, k2_iv):
    """The band holding the whole S interval; plane when both k intervals hold 0."""
    if k1_iv[0] <= 0 <= k1_iv[1] and k2_iv[0] <= 0 <= k2_iv[1]:
        return "plane"
    for name, (lo, hi) in BANDS.items():
        if lo <= S_iv[0] and S_iv[1] <= hi:
            return name
    return "uncertain"


def analyze(patches, positions_only=False):
    """[Jet2Result or DataError] for dicts with ``points``, ``normals`` and optionally
    ``noise_pos``, ``noise_normal`` (used when ``stated`` is true).  ``positions_only``:
    the quadric jet of the heights alone (the usual jet fit, no normals)."""
    out = [None] * len(patches)
    groups = {}
    for j, d in enumerate(patches):
        groups.setdefault(len(d["points"]), []).append(j)
    for idx in groups.values():
        P = np.stack([np.asarray(patches[j]["points"], float) for j in idx])
        N = np.stack([np.asarray(patches[j]["normals"], float) for j in idx])
        told = [patches[j].get("stated", False) for j in idx]
        sp = np.array([patches[j]["noise_pos"] if t else np.nan for j, t in zip(idx, told)])
        sn = np.array([patches[j]["noise_normal"] if t else np.nan for j, t in zip(idx, told)])
        f = fit_group(P, N, sp, sn, positions_only=positions_only)
        for b, j in enumerate(idx):
            out[j] = _result(f, b)
    return out


def _result(f, b):
    if not f["ok"][b] or not np.all(np.isfinite(f["qcov"][b])):
        return DataError(f"2-jet: {f['why'][b] or 'no spare rows for its noise'}")
    q, sd = f["q"][b], np.sqrt(np.maximum(np.diagonal(f["qcov"][b]), 0.0))
    k1_iv = (q[0] - Z95 * sd[0], q[0] + Z95 * sd[0])
    k2_iv = (q[1] - Z95 * sd[1], q[1] + Z95 * sd[1])
    S_iv = (max(q[2] - Z95 * sd[2], -1.0), min(q[2] + Z95 * sd[2], 1.0))
    shape = label(q[2], S_iv, k1_iv, k2_iv)
    return Jet2Result(
        S=float(q[2]), k1=float(q[0]), k2=float(q[1]), S_interval=S_iv, k1_interval=k1_iv,
        k2_interval=k2_iv, shape=shape, confidence=0.0 if shape == "uncertain" else 0.95,
        frame=PatchFrame(f["origin"][b], f["rot"][b]), box=tuple(f["box"][b]),
        scale=float(f["L"][b]), centre=f["centre"][b], noise_pos=float(f["sig_p"][b]),
        noise_normal=float(f["sig_n"][b]),
    )  # fmt: skip


def worst_halfwidth(P, N, sig_p, sig_n):
    """(B,) the 95 % half-width, times L, of the normal curvature in its worst direction at
    the given noise (Fisher information of the rows, no chi^2 factor): the data determine
    the curvature where it is at most 0.25 (docs/ep2.md, "What is null")."""
    f = fit_group(P, N, sig_p, sig_n, fisher=True)
    t = np.linspace(0, np.pi, 37)[:-1]
    w = np.stack([np.cos(t) ** 2, 2 * np.cos(t) * np.sin(t), np.sin(t) ** 2], axis=-1)
    var = np.einsum("ti,bij,tj->bt", w, f["cov"][:, 3:, 3:], w)
    return Z95 * np.sqrt(var.max(axis=-1))


def positions(patches):
    """``analyze`` of the heights alone: the quadric jet without normals."""
    return analyze(patches, positions_only=True)
