"""The crease, tilt and curvature-jump checks' screens for a stack of patches of one size.

``edges.check``, ``tilt.untilt`` and ``curvature_jump.find_jump`` look at one patch at a time; on
smooth data nearly every patch passes them.  ``clear`` and ``no_jump`` compute, for a
stack of like-sized prepared patches, the numbers those checks decide on (the normals'
gate and the step against the smooth field, the normal screen's far contacts; the tilt's
fit, its chi^2, size and standard error; the jump's first test, a smooth change of the
slopes against a constant curvature) with stacked NumPy (``eigh``, normal equations) and
say which patches pass each check by a margin (``REL``, ``ABS``) far beyond the two
computations' round-off.  Only the others run the per-patch check, so the answers are the
per-patch checks' exactly: a patch near a threshold, with tied normals or an
ill-conditioned fit is always checked one at a time.
"""

import numpy as np

from tactile.ep2 import curvature_jump, edges, tilt

REL = 1e-6  # relative margin on every decision
ABS = 1e-9  # absolute margin, in units of the quantity's scale
MAX_COND = 1e3  # a fit's condition number beyond which the screen leaves it to the check
TILT_COND = 1e4  # the same for the tilt's weighted fit (its rows' scales differ)
TILT_REL = 1e-3  # the tilt's margin: its fit's inverse is less accurate than the rest
QR_COND = 1e4  # the same for a fit by QR (its residual's error grows as cond, not cond^2)
GAP = 1e-3  # the slopes' gradient's eigenvalues this share apart, or its axes are left to the check
DIR = 1e-8  # a fit's coefficients' error, relative: its axes may turn by this over the gap
SEED_ROWS = 64  # contacts up to which every seed of the normal screen that ties is tried


def clear(points, normals, opts):
    """(edges clear (B,), tilt clear (B,)): whether ``edges.check`` passes (raises nothing)
    and whether ``tilt.untilt`` leaves the patch as it is, for ``points``, ``normals`` (B, n, 3)
    of prepared patches (centred, unit normals) with options ``opts`` (``JetOptions``, one per
    patch)."""
    noise_pos = np.array([np.nan if o.noise_pos is None else o.noise_pos for o in opts], float)
    noise_normal = np.array([np.nan if o.noise_normal is None else o.noise_normal for o in opts])
    cosmax = np.cos(np.radians([o.max_normal_angle for o in opts]))
    edge = _no_edge(points, normals) & _few_far(normals, cosmax)
    return edge, _no_tilt(points, normals, noise_pos, noise_normal)


def no_jump(points, normals, mask=None):
    """(B,) whether ``curvature_jump.find_jump`` surely finds no jump, for ``points``,
    ``normals`` (B, n, 3) of prepared patches (as fitted: after ``tilt.untilt``), padded
    where ``mask`` (B, n) is False (None: none is): its gates (too few contacts, a normal
    near the tangent plane), its first test (the slopes' quadratic field no better than
    their linear one, by ``JUMP_PRE``) or its hinges' (``_no_hinge``), by the margins."""
    mask = np.ones(points.shape[:2], bool) if mask is None else mask
    k = mask.sum(axis=1)
    if k.max() < curvature_jump.MIN_POINTS:
        return np.ones(len(k), bool)
    points, normals = points * mask[..., None], normals * mask[..., None]
    total = normals.sum(axis=1)
    size = np.linalg.norm(total, axis=-1)
    live = size > 1e-6
    m = np.where(live[:, None], total / np.where(live, size, 1.0)[:, None], [0.0, 0.0, 1.0])
    nz = np.einsum("bnk,bk->bn", normals, m)
    zmin = np.where(mask, nz, np.inf).min(axis=1)
    low = live & (zmin < 0.1 * (1 - REL))  # (``find_jump`` returns None: a normal near the plane)
    sure = live & (low | (zmin > 0.1 * (1 + REL)))
    t1, t2 = _across(m)
    xy = np.stack([np.einsum("bnk,bk->bn", points, t) for t in (t1, t2)], axis=-1)
    inside = mask[..., None]
    L = np.where(inside, xy, -np.inf).max(axis=1) + np.where(inside, -xy, -np.inf).max(axis=1)
    L = L.max(axis=1)  # (each one's ptp over the patch's rows)
    sure &= L > ABS * np.abs(points).max(axis=(1, 2))
    xy = (xy - xy.sum(axis=1, keepdims=True) / k[:, None, None]) * inside
    xy /= np.where(L > 0, L, 1.0)[:, None, None]
    nz = np.where(low[:, None] | ~mask, 1.0, nz)
    s = -np.stack([np.einsum("bnk,bk->bn", normals, t) for t in (t1, t2)], axis=-1) / nz[..., None]
    x, y = xy[..., 0], xy[..., 1]
    quad = np.stack([mask.astype(float), x, y, x * x, x * y, y * y], axis=-1)
    coef_q, ok = _solve(quad, s)
    res = np.sum((quad @ coef_q - s) ** 2, axis=(1, 2))
    coef, ok3 = _solve(quad[..., :3], s)
    flat = np.sum((quad[..., :3] @ coef - s) ** 2, axis=(1, 2))
    sure &= ok & ok3
    slack = REL * (flat + res) + ABS * np.sum(s * s, axis=(1, 2))
    none = flat - res + slack < curvature_jump.JUMP_PRE * res / np.maximum(k - 6, 1) * (1 - REL)
    todo = np.flatnonzero(sure & ~none)
    if todo.size:  # (the smooth change beats a constant curvature: the hinges, stacked)
        none[todo] = _no_hinge(xy[todo], s[todo], quad[todo], coef_q[todo], mask[todo])
    return (k < curvature_jump.MIN_POINTS) | low | sure & none


def _no_hinge(xy, s, quad, coef, mask):
    """(B,) whether ``find_jump`` surely finds no hinge along either axis of the slopes'
    gradient, for patches past its first test: the same gross contacts left out (each one's
    residual, and the next one's, clear of the cut-off by the margins), axes told apart
    (their eigenvalues ``GAP`` apart), and on each axis either its first test fails or the
    best cut's residual (every cut, each way, stably: a lower bound on the check's, whose
    ridge only adds to it) fails ``JUMP_RATIO`` or ``JUMP_F``, by the margins widened by how
    far the axes may turn between the two fits."""
    cj = curvature_jump
    scale = np.sum(s * s, axis=(1, 2))
    r = np.sqrt(np.sum((quad @ coef - s) ** 2, axis=2))
    keep, sure = _kept(r, mask, REL * np.sqrt(scale))
    w, V = np.linalg.eigh(coef[:, 1:3] + np.swapaxes(coef[:, 1:3], 1, 2))
    spread = np.abs(w).max(axis=1)
    gap = w[:, 1] - w[:, 0]
    sure &= gap > GAP * spread
    slack = (ABS + DIR * spread / np.maximum(gap, 1e-300)) * scale
    m = keep.sum(axis=1)
    dof = np.maximum(m - 5, 1)
    one = keep.astype(float)
    none = np.ones(len(xy), bool)
    for e in np.swapaxes(V, 1, 2).transpose(1, 0, 2):  # (each axis: (B, 2))
        u = np.einsum("bnk,bk->bn", xy, e) * one
        v = np.einsum("bnk,bk->bn", xy, np.stack([-e[:, 1], e[:, 0]], axis=1)) * one
        y = np.einsum("bnk,bk->bn", s, e) * one
        shared, ok = _basis_of([one / np.sqrt(m)[:, None], v])  # (each cut's columns: 1, v)
        lin, ok1 = _basis_of([u, u * v], shared)
        smooth, ok2 = _basis_of([u * u], lin)
        sure &= ok & ok1 & ok2
        lin, smooth = (np.sum(_less(y, q) ** 2, axis=-1) for q in (lin, smooth))
        sl = REL * (lin + smooth) + slack
        pre = lin - smooth + sl < cj.JUMP_PRE * (smooth - sl) / dof * (1 - REL)
        best, ok = _best_hinge(u, v, y, keep, m, shared)
        lo, sure = best * (1 - REL) - slack, sure & (ok | pre)
        search = lo > cj.JUMP_RATIO * (smooth * (1 + REL) + slack)
        search |= lin * (1 + REL) + slack - lo < cj.JUMP_F * lo / dof * (1 - REL)
        none &= pre | search
    return sure & none


def _basis_of(xs, qs=()):
    """(``qs`` and the columns ``xs`` orthonormalised after them in turn (modified
    Gram-Schmidt), whether each one's rest is over 1 / ``QR_COND`` of its length)."""
    qs, ok = list(qs), True
    for x in xs:
        q, good = _next_q(x, qs)
        qs, ok = [*qs, q], ok & good
    return qs, ok


def _kept(r, mask, mrg):
    """(the contacts ``find_jump`` keeps (B, n) of those in ``mask``, whether surely the
    same: the largest ``MAX_LEFT_OUT`` residuals r (B, n), and the next, clear of its
    cut-off by ``mrg`` (B,) and by ``REL`` of it)."""
    k, (B, n) = curvature_jump.MAX_LEFT_OUT, r.shape
    order = np.sort(np.where(mask, r, -1.0), axis=1)  # (the padding first)
    c = mask.sum(axis=1)
    b = np.arange(B)
    median = 0.5 * (order[b, n - c + (c - 1) // 2] + order[b, n - c + c // 2])
    cut = curvature_jump.JUMP_GROSS * 1.4826 * median
    mrg = mrg + REL * cut
    top = order[:, ::-1][:, : k + 1]  # the largest, and the next
    gross = top[:, :k] > cut[:, None]
    sure = np.all(np.abs(top[:, :k] - cut[:, None]) > mrg[:, None], axis=1)
    sure &= ~gross[:, -1] | (top[:, -2] - top[:, -1] > mrg)  # (the left-out set is certain)
    return mask & (r < np.where(gross, top[:, :k], np.inf).min(axis=1)[:, None]), sure


def _best_hinge(u, v, y, keep, m, shared):
    """(the least residual over ``find_jump``'s cuts, each way, of a hinge on u; whether
    every fit's condition number is surely under about ``QR_COND``) (B,) each.  Rows not
    kept are zero and sort last: patch b's cuts are between its m[b] kept u's sorted.  Each
    cut's fit by modified Gram-Schmidt (backward stable for a residual, as QR): y and the
    hinge's columns h, h v less their projections on the columns all cuts share (1, v),
    then on h's rest, then on h v's."""
    side = curvature_jump.MIN_SIDE
    n = u.shape[1]
    us = np.sort(np.where(keep, u, np.inf), axis=1)
    idx = np.arange(side - 1, n - side)
    valid = idx[None] < (m - side)[:, None]
    c = np.where(valid, 0.5 * (us[:, idx] + us[:, idx + 1]), 0.0)  # (inf past the kept)
    c = np.concatenate([c, c], axis=1)[..., None]  # (B, 2C, 1)
    sign = np.repeat([1.0, -1.0], len(idx))[None, :, None]
    one = keep.astype(float)
    h = np.maximum(sign * (u[:, None] - c), 0.0) * one[:, None]
    Q = np.stack(shared, axis=-1)  # (B, n, 2): classical Gram-Schmidt on them, then modified
    cols = (h, h * v[:, None])
    rest = [x - (x @ Q) @ np.swapaxes(Q, 1, 2) for x in cols]
    along = _dot(rest[1], rest[0]) / _safe(_dot(rest[0], rest[0]))
    rest[1] = rest[1] - rest[0] * along[..., None]
    size = [_dot(r, r) for r in rest]
    ok = np.all([z * QR_COND**2 > _dot(x, x) for z, x in zip(size, cols)], axis=0)
    q2, q3 = (r / np.sqrt(_safe(z))[..., None] for r, z in zip(rest, size))
    ry = _less(y, shared)[..., None]  # (the rest by Pythagoras: its error ~ eps |y|^2)
    rss = np.sum(ry * ry, axis=(1, 2))[:, None] - (q2 @ ry)[..., 0] ** 2 - (q3 @ ry)[..., 0] ** 2
    valid = np.concatenate([valid, valid], axis=1)
    rss = np.where(valid, rss, np.inf).min(axis=1)
    return rss, np.all(ok | ~valid, axis=1)


def _dot(a, b):
    return np.einsum("...n,...n->...", a, b)


def _safe(z):
    return np.where(z > 0, z, 1.0)


def _less(x, qs):
    """x (..., n) less its projection on each unit q (..., n) of ``qs`` in turn."""
    for q in qs:
        x = x - q * np.sum(x * q, axis=-1, keepdims=True)
    return x


def _next_q(x, qs):
    """(x (..., n) less its projections on ``qs`` (orthonormal), as a unit vector; whether
    its rest is over 1 / ``QR_COND`` of its length: else the columns are near dependent)."""
    r = _less(x, qs)
    size = np.sqrt(np.sum(r * r, axis=-1))
    ok = size > np.sqrt(np.sum(x * x, axis=-1)) / QR_COND
    return r / np.where(ok, size, 1.0)[..., None], ok


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _across(m):
    """``edges._basis`` / ``tilt._frame`` of each unit row of m: (t1, t2) (B, 3) each."""
    ref = np.where(np.abs(m[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = _unit(np.cross(m, ref))
    return t1, np.cross(m, t1)


def no_turn(points, normals, opts=None):
    """(B,) whether ``edges.find``, strict or loose, surely stops at its gate (too few
    contacts, or every normal within ``edges.GATE_DEG`` of the mean), by the margins: then
    ``edges.check_answer`` has nothing to say of a ``plane`` or a refusal.  (``opts``: as
    ``clear`` takes them; the gate has none.)"""
    B, n, _ = points.shape
    if n < edges.MIN_POINTS:
        return np.ones(B, bool)
    gate, _, size = _gate(normals)
    return gate & (size > 1e-3)  # (normals within the gate sum to about n)


def _gate(N):
    """(``edges.find``'s gate passed by ``ABS``, the normals' sum, its length) (B,) each."""
    total = N.sum(axis=1)
    size = np.linalg.norm(total, axis=-1)
    low = np.einsum("bnk,bk->bn", N, total).min(axis=1)
    return low - np.cos(np.radians(edges.GATE_DEG)) * size > ABS * size, total, size


def _no_edge(P, N):
    """Whether ``edges.find`` (strict) surely finds no edge: every normal near the mean
    (the gate), or the best step not under ``STEP_RATIO`` of the smooth field's residual
    and a side's normals scattered beyond flat faces' (``edges.flat_faces``)."""
    B, n, _ = P.shape
    if n < edges.MIN_POINTS:
        return np.ones(B, bool)
    gate, total, size = _gate(N)
    out = gate.copy()
    todo = np.flatnonzero(~gate & (size > 1e-6))
    if todo.size:
        out[todo] = _step_loses(P[todo], N[todo], total[todo] / size[todo, None])
    return out


def _step_loses(P, N, m):
    """``edges.find``'s ``rss_step > STEP_RATIO * smooth rss`` and not flat faces, by the
    margins (else False)."""
    n = P.shape[1]
    C = _gram(N - N.mean(axis=1, keepdims=True)) / (n - 1)
    w, V = np.linalg.eigh(C)
    a = V[:, :, -1]
    x = np.einsum("bnk,bk->bn", N, a)
    order = np.argsort(x, axis=1)
    xs = np.take_along_axis(x, order, axis=1)
    gap = np.diff(xs, axis=1).min(axis=1)
    sure = (w[:, -1] - w[:, -2] > REL * w[:, -1]) & (gap > REL * np.ptp(x, axis=1))
    gs = np.take_along_axis(N, order[..., None], axis=1)
    c1 = np.cumsum(gs, axis=1)
    c2 = np.cumsum(np.sum(gs**2, axis=2), axis=1)
    k = np.arange(1, n)
    left = c2[:, :-1] - np.sum(c1[:, :-1] ** 2, axis=2) / k
    right = (c2[:, -1:] - c2[:, :-1]) - np.sum((c1[:, -1:] - c1[:, :-1]) ** 2, axis=2) / (n - k)
    ok = (k >= edges.MIN_SIDE) & (n - k >= edges.MIN_SIDE)
    rss = np.where(ok, left + right, np.inf)
    j = np.argmin(rss, axis=1)
    rss_step = rss[np.arange(len(j)), j]
    sure &= _scattered(c1, left, right, j, k)
    t1, t2 = _across(m)
    xy = np.stack([np.einsum("bnk,bk->bn", P, t) for t in (t1, t2)], axis=-1)
    xy = xy - xy.mean(axis=1, keepdims=True)
    xy = xy / np.maximum(np.ptp(xy, axis=(1, 2)), 1e-300)[:, None, None]
    u, v = xy[..., 0], xy[..., 1]
    A = np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)
    coef, ok = _solve(A, N)
    sure &= ok  # (a coefficient off the least squares' only adds to rss_smooth: the safe side)
    rss_smooth = np.sum((N - A @ coef) ** 2, axis=(1, 2))
    bound = edges.STEP_RATIO * rss_smooth * (1 + REL) + ABS * n
    return sure & (rss_step > bound)


def _scattered(c1, left, right, j, k):
    """Whether a side of the best cut (index ``j`` into the cuts ``k``) surely scatters over
    ``edges.TIGHT`` of the step between the sides' means: ``edges.flat_faces`` is False."""
    b = np.arange(len(j))
    kj = k[j]
    n = k[-1] + 1
    m1 = c1[b, j] / kj[:, None]
    m2 = (c1[b, -1] - c1[b, j]) / (n - kj)[:, None]
    step = np.linalg.norm(m2 - m1, axis=1)
    rms = np.sqrt(np.maximum(np.maximum(left[b, j] / kj, right[b, j] / (n - kj)), 0.0))
    return rms > edges.TIGHT * step * (1 + REL) + ABS


def _few_far(N, cosmax):
    """Whether ``edges.check``'s normal screen surely leaves out at most ``MAX_LEFT_OUT``."""
    dots = np.einsum("bnk,bk->bn", N, N.sum(axis=1))
    seed = np.argmax(dots, axis=1)
    if N.shape[1] <= SEED_ROWS:
        seeds = N @ np.swapaxes(N, -1, -2) - cosmax[:, None, None]  # (seed n, contact m)
        near = seeds[np.arange(len(N)), seed]
        sure = _same_near(dots, seeds, near)
    else:  # (a seed that ties the next: left to the check)
        top = np.sort(dots, axis=1)[:, -2:]
        near = np.einsum("bnk,bk->bn", N, N[np.arange(len(N)), seed]) - cosmax[:, None]
        sure = top[:, 1] - top[:, 0] > REL * np.abs(dots).max(axis=1)
        sure &= np.all(np.abs(near) > REL, axis=1)
    mean = _unit(np.einsum("bn,bnk->bk", (near > 0).astype(float), N))
    cos = np.einsum("bnk,bk->bn", N, mean)
    sure &= np.all(np.abs(cos - cosmax[:, None]) > REL, axis=1)
    far = np.sum(cos <= cosmax[:, None], axis=1)
    return sure & (far <= edges.MAX_LEFT_OUT)


def _same_near(dots, seeds, near):
    """Whether the contacts near the seed (``near``, (B, n): each one's cosine to it less
    the limit's) are surely those near the check's seed: every contact whose dot with the
    normals' sum ties the largest (the check's argmax, to round-off) puts, as the seed
    (``seeds`` (B, n, n)), the same contacts near, each by ``REL``.  Noise-free patches
    laid out symmetrically tie."""
    scale = np.abs(dots).max(axis=1, keepdims=True)
    tied = dots >= dots.max(axis=1, keepdims=True) - REL * scale
    same = np.all(np.abs(seeds) > REL, axis=2) & np.all((seeds > 0) == (near > 0)[:, None], 2)
    return np.all(same | ~tied, axis=1)


def _no_tilt(P, N, noise_pos, noise_normal):
    """Whether ``tilt.untilt`` surely names no tilt (``tilt.estimate``'s fit, stacked)."""
    B, n, _ = P.shape
    out = np.zeros(B, bool)
    if n < tilt.MIN_POINTS:
        return ~out
    total = N.sum(axis=1)
    size = np.linalg.norm(total, axis=-1)
    live = np.flatnonzero(size > 1e-6)
    if not live.size:
        return out
    P, N, noise_pos, noise_normal = P[live], N[live], noise_pos[live], noise_normal[live]
    m = total[live] / size[live, None]
    R = np.stack([*_across(m), m], axis=1)  # rows: x, y, z
    local = (P - P.mean(axis=1, keepdims=True)) @ R.transpose(0, 2, 1)
    L = np.maximum(np.ptp(local[..., 0], axis=1), np.ptp(local[..., 1], axis=1))
    nl = N @ R.transpose(0, 2, 1)
    zmin = nl[..., 2].min(axis=1)
    sure = L > ABS * np.abs(P).max(axis=(1, 2))
    steep = sure & (zmin < 0.1 - REL)  # ``estimate``: a normal near the tangent plane
    sure &= steep | (zmin > 0.1 + REL)
    Ls = np.where(sure, L, 1.0)
    x, y, z = (local / Ls[:, None, None]).transpose(2, 0, 1)
    nz = np.where(nl[..., 2] > 0.05, nl[..., 2], 1.0)  # (only where none is under 0.1)
    sx, sy = -nl[..., 0] / nz, -nl[..., 1] / nz
    one, zero = np.ones_like(x), np.zeros_like(x)
    H = np.stack([one, x, y, x * x / 2, x * y, y * y / 2, zero, zero], axis=-1)
    Sx = np.stack([zero, one, zero, x, y, zero, one, zero], axis=-1)
    Sy = np.stack([zero, zero, one, zero, x, y, zero, one], axis=-1)
    sp, ok = _qr_residual(H[..., :6], z, n - 6)  # (sweeps' quadratic columns: cond ~ 1e3)
    sp = np.fmax(sp, noise_pos / Ls)  # (NaN where not stated: the residual alone)
    sure &= ok
    r, ok = _residual(H[..., :3], np.stack([sx, sy], axis=-1), n - 3)
    sn = np.fmax(np.hypot(r[:, 0], r[:, 1]) / np.sqrt(2), noise_normal)
    sure &= ok
    sp, sn = np.maximum(sp, tilt.NOISE_FLOOR), np.maximum(sn, tilt.NOISE_FLOOR)
    A = np.concatenate([H / sp[:, None, None], Sx / sn[:, None, None], Sy / sn[:, None, None]], 1)
    b = np.concatenate([z / sp[:, None], sx / sn[:, None], sy / sn[:, None]], axis=1)
    rhs = np.concatenate([A.transpose(0, 2, 1) @ b[..., None], np.zeros((len(A), 8, 8))], -1)
    rhs[:, np.arange(8), 1 + np.arange(8)] = 1.0  # [A^T b | I]: the solution and the inverse
    sol, ok = _solve(A, None, rhs, TILT_COND)
    sure &= ok
    coef, inv = sol[..., 0], sol[..., 1:]
    chi2 = np.sum(((A @ coef[..., None])[..., 0] - b) ** 2, axis=1) / max(3 * n - 8, 1)
    cov = inv[:, 6:, 6:] * np.maximum(chi2, 1.0)[:, None, None]
    tb = coef[:, 6:]
    big = np.hypot(tb[:, 0], tb[:, 1])
    u = tb / np.maximum(big, 1e-300)[:, None]
    se = np.sqrt(np.maximum(np.einsum("bi,bij,bj->b", u, cov, u), 0.0))
    deg = np.degrees(np.arctan(big))
    none = chi2 > tilt.MAX_CHI2 * (1 + TILT_REL)
    none |= (deg < tilt.MIN_DEG * (1 - TILT_REL)) | (deg > tilt.MAX_DEG * (1 + TILT_REL))
    none |= big < tilt.MIN_Z * se * (1 - TILT_REL)
    out[live] = steep | sure & none
    return out


def _gram(A):
    return A.transpose(0, 2, 1) @ A


def _solve(A, Y, rhs=None, max_cond=MAX_COND):
    """(the normal equations' solution (B, k, m) of A (B, n, k) against Y (B, n, m), or
    against ``rhs`` (B, k, m) as given; whether A's condition number is surely under
    ``MAX_COND``, so that it is within the margins of ``np.linalg.lstsq``'s) per patch.
    The bound: cond(G) <= |G|_F |G^-1|_F (G = A^T A), an inverse costing a fraction of G's
    eigenvalues; a patch it fails is left to the check."""
    G = _gram(A)
    try:
        inv = np.linalg.inv(G)
    except np.linalg.LinAlgError:  # (an exactly singular G in the stack)
        w = np.linalg.eigvalsh(G)
        ok = w[:, 0] > w[:, -1] / max_cond**2
        G[~ok] = np.eye(G.shape[-1])  # (left to the check: any solvable system)
        inv = np.linalg.inv(G)
    else:
        with np.errstate(over="ignore", invalid="ignore"):
            bound = np.sqrt(np.sum(G * G, axis=(1, 2)) * np.sum(inv * inv, axis=(1, 2)))
        ok = bound < max_cond**2
        inv[~ok] = np.eye(G.shape[-1])  # (any finite solution: the check decides)
    if rhs is None:
        rhs = A.transpose(0, 2, 1) @ Y
    return inv @ rhs, ok


def _residual(A, y, dof):
    """(rms residual (B,) or (B, m) of y (B, n) or (B, n, m) fitted by A's columns, with
    ``dof`` spare rows; ``_solve``'s ok) per patch."""
    Y = y if y.ndim == 3 else y[..., None]
    coef, ok = _solve(A, Y)
    rms = np.sqrt(np.sum((A @ coef - Y) ** 2, axis=1) / max(dof, 1))
    return (rms if y.ndim == 3 else rms[:, 0]), ok


def _qr_residual(A, y, dof):
    """``_residual`` of y (B, n) by ``_qr_rss``, and its ok."""
    rss, ok = _qr_rss(A, y)
    return np.sqrt(rss / max(dof, 1)), ok


def _qr_rss(A, y):
    """(the residual sum of squares (B,) of y (B, n) fitted by A's columns, by Householder QR:
    within about cond(A) eps of ``np.linalg.lstsq``'s (the normal equations': cond^2 eps);
    whether cond(A) is surely under ``QR_COND`` (by ||R||_F ||R^-1||_F)) per patch."""
    Q, R = np.linalg.qr(A)
    d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    tiny = ~(d > 1e-12 * np.maximum(d.max(axis=-1, keepdims=True), 1e-300))
    Rinv = np.linalg.inv(R + np.eye(R.shape[-1]) * tiny[:, None, :])
    with np.errstate(over="ignore", invalid="ignore"):
        bound = np.sqrt(np.sum(R * R, axis=(1, 2)) * np.sum(Rinv * Rinv, axis=(1, 2)))
    ok = ~tiny.any(axis=-1) & (bound < QR_COND)
    r = y - (Q @ (np.swapaxes(Q, -1, -2) @ y[..., None]))[..., 0]
    return np.sum(r * r, axis=1), ok
