"""A curvature jump: a plane joined tangentially to a curved surface, inside one patch.

The normals' slope s over the tangent plane changes smoothly on a smooth surface; across
a tangent join it is constant on one side (the plane) and turns linearly on the other.
``find_jump`` fits, along each axis u of the slopes' gradient, a hinge (s constant on one
side of u0, linear on the other) against a smooth change (s quadratic in u) and a constant
curvature (s linear in u), after leaving out up to ``MAX_LEFT_OUT`` gross contacts.
``check`` makes a fitted label (not ``plane``) ``uncertain`` across such a jump, with a
warning placing it; S, k1, k2 and their intervals stay the smooth fit's.

``no_jump`` screens a stack of patches at once (``check_screens`` has the other checks'
screens and takes this one's margins and stacked fits): it computes the numbers
``find_jump`` decides on, stably and stacked, and clears a patch only where every one of
them passes by a margin (``REL``, ``ABS``) far beyond the two computations' round-off, so
the answers are ``find_jump``'s exactly.
"""

import numpy as np

from tactile.errors import DataError

MIN_POINTS = 10  # contacts, the gross ones left out included
MIN_SIDE = 3  # contacts each side of the hinge
MAX_LEFT_OUT = 2  # the normal screen's most (docs/ep2.md)
JUMP_RATIO = 0.8  # a hinge's residual under this share of a smooth change's
JUMP_GROSS = 5.0  # a contact the smooth change misses by this many robust sigmas: an outlier
JUMP_F = 30.0  # and this many times the noise better than a constant curvature
JUMP_PRE = 10.0  # the smooth change's own F against a constant curvature, to look at all

# The stacked screen's margins (``check_screens`` takes them too): far beyond round-off
REL = 1e-6  # relative margin on every decision
ABS = 1e-9  # absolute margin, in units of the quantity's scale
MAX_COND = 1e3  # a fit's condition number beyond which the screen leaves it to the check
QR_COND = 1e4  # the same for a fit by QR (its residual's error grows as cond, not cond^2)
GAP = 1e-3  # the slopes' gradient's eigenvalues this share apart, else left to the check
DIR = 1e-7  # a fit's coefficients' error, relative (cond^2 eps at QR_COND, and more):
# the gradient's axes may turn by this over the eigenvalues' gap


def _unit(v):
    return v / np.linalg.norm(v)


def tangent_basis(m):
    """(3, 2): two unit vectors across the unit vector m (m x ref, then m x that: ``np.cross``
    written out, which costs more than the rest on 3-vectors)."""
    a, b, c = m
    t1 = np.array([0.0, c, -b]) if abs(a) < 0.9 else np.array([-c, 0.0, a])  # ref x, or y
    t1 /= np.sqrt(t1 @ t1)
    x, y, z = t1
    return np.array([[x, b * z - c * y], [y, c * x - a * z], [z, a * y - b * x]])


def find_jump(points, normals):
    """(point, direction) of a curvature jump the contacts straddle, in their frame, or
    None.  Along an axis u of the gradient of the normals' slope s (the better fitted), a
    hinge (s constant on one side of u0, linear on the other: a plane joined tangentially
    to a curved surface) leaves under ``JUMP_RATIO`` of a smooth change's residual (s
    quadratic in u) and fits over ``JUMP_F`` times better than a constant curvature (s
    linear in u) by an F test; looked for only where the smooth change beats the constant
    curvature by ``JUMP_PRE`` over the patch and along u.  Up to ``MAX_LEFT_OUT`` contacts
    a quadratic slope field misses by ``JUMP_GROSS`` robust sigmas are left out first."""
    pts, nrm = np.asarray(points, float), np.asarray(normals, float)
    m = _unit(nrm.sum(axis=0))
    if len(pts) < MIN_POINTS or np.min(nrm @ m) <= 0.1:
        return None
    T = tangent_basis(m)
    xy = pts @ T
    L = np.ptp(xy, axis=0).max()
    if not L > 0:
        return None
    xy = (xy - xy.mean(axis=0)) / L
    s = -(nrm @ T) / (nrm @ m)[:, None]
    x, y = xy.T
    quad = np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])
    coef = _solve(quad, s)
    res = np.sum((quad @ coef - s) ** 2, axis=1)
    flat = float(np.sum((quad[:, :3] @ _solve(quad[:, :3], s) - s) ** 2))
    if flat - res.sum() <= JUMP_PRE * res.sum() / max(len(s) - 6, 1):
        return None  # the curvature does not change over the patch
    V = np.linalg.eigh(coef[1:3] + coef[1:3].T)[1]  # the slopes' gradient's axes
    res = np.sqrt(res)
    order = np.argsort(res)
    gross = order[::-1][:MAX_LEFT_OUT]
    gross = gross[res[gross] > JUMP_GROSS * 1.4826 * _median(res[order])]
    keep = np.ones(len(xy), bool)
    keep[gross] = False
    xy, s = xy[keep], s[keep]
    found = [(*_hinge(xy @ e, xy @ [-e[1], e[0]], s @ e), e) for e in V.T]
    found = [f for f in found if f[0] is not None]
    if not found:
        return None
    u0, _, e = min(found, key=lambda f: f[1])  # (each axis of the gradient: the better)
    return pts.mean(axis=0) + T @ (u0 * L * e), T @ [-e[1], e[0]]


def _hinge(u, v, y):
    """(the hinge's u0, its residual over the smooth change's), or (None, None) short of
    ``find_jump``'s tests: every cut between neighbouring u with ``MIN_SIDE`` contacts a
    side, each way, at once (normal equations, a ridge of 1e-12 of the trace)."""
    n, one = len(u), np.ones_like(u)
    lin = _rss(np.column_stack([one, u, v, u * v]), y)
    smooth = _rss(np.column_stack([one, u, u * u, v, u * v]), y)
    if lin - smooth <= JUMP_PRE * smooth / max(n - 5, 1):
        return None, None  # the curvature does not change along u
    us = np.sort(u)
    cuts = 0.5 * (us[MIN_SIDE - 1 : n - MIN_SIDE] + us[MIN_SIDE : n - MIN_SIDE + 1])
    if not len(cuts):
        return None, None
    cuts = np.concatenate([cuts, cuts])
    side = np.repeat([1.0, -1.0], len(cuts) // 2)
    h = np.maximum(side[:, None] * (u[None] - cuts[:, None]), 0.0)
    A = np.stack([np.broadcast_to(one, h.shape), h, np.broadcast_to(v, h.shape), h * v], -1)
    G = A.transpose(0, 2, 1) @ A
    G += 1e-12 * np.trace(G, axis1=1, axis2=2)[:, None, None] * np.eye(4)
    coef = np.linalg.solve(G, (A.transpose(0, 2, 1) @ y)[..., None])
    rss = np.sum(((A @ coef)[..., 0] - y) ** 2, axis=-1)
    j = int(np.argmin(rss))
    best, u0 = float(rss[j]), float(cuts[j])
    gain = (lin - best) / max(best / max(n - 5, 1), 1e-300 * lin)
    if best >= JUMP_RATIO * smooth or gain <= JUMP_F:
        return None, None
    return u0, best / max(smooth, 1e-300)


def _median(ordered):
    """``np.median`` of values already in ascending order (the same number; NaN sorts last)."""
    n = len(ordered)
    if np.isnan(ordered[-1]):
        return np.nan
    return ordered[n // 2] if n % 2 else (ordered[n // 2 - 1] + ordered[n // 2]) / 2


def _rss(A, y):
    return float(np.sum((A @ _solve(A, y) - y) ** 2))


def _solve(A, y):
    """Least squares by the normal equations (unit-sized columns), a ridge of 1e-12 of the
    trace for a column the contacts leave undetermined."""
    G = A.T @ A
    G.flat[:: len(G) + 1] += 1e-12 * np.trace(G)
    return np.linalg.solve(G, A.T @ y)


def check(prep, out):
    """A fitted answer (not ``plane``) across a curvature jump: ``uncertain``, and said."""
    if isinstance(out, DataError) or out.centre.shape in ("plane", "uncertain"):
        return
    got = find_jump(prep.points, prep.normals)
    if got is None:
        return
    where = (got[0] + prep.middle, got[1])
    p, d = (", ".join(f"{x:{f}}" for x in v) for v, f in zip(where, (".4g", ".3f"), strict=True))
    out.centre.shape = "uncertain"
    out.warnings = [*out.warnings,
                       f"a curvature jump at ({p}) along ({d}): one side's normals keep their"
                       " slope, the other's turn (a plane joined to a curved surface?); the"
                       " label is uncertain: fit each side alone"]  # fmt: skip


# --- The stacked screen: for many patches at once, whether ``find_jump`` surely finds nothing.


def no_jump(points, normals, mask=None):
    """(B,) whether ``find_jump`` surely finds no jump, for ``points``,
    ``normals`` (B, n, 3) of prepared patches (as fitted: after ``tilt.untilt``), padded
    where ``mask`` (B, n) is False (None: none is): its gates (too few contacts, a normal
    near the tangent plane), its first test (the slopes' quadratic field no better than
    their linear one, by ``JUMP_PRE``) or its hinges' (``_no_hinge``), by the margins."""
    mask = np.ones(points.shape[:2], bool) if mask is None else mask
    k = mask.sum(axis=1)
    if k.max() < MIN_POINTS:
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
    t1, t2 = tangent_bases(m)
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
    Q, coef_q, res, ok = qr_fit(quad, s)
    Q3 = Q[..., :3]  # (Householder's first columns: the linear columns' own QR)
    flat = np.sum((s - Q3 @ (np.swapaxes(Q3, 1, 2) @ s)) ** 2, axis=(1, 2))
    sure &= ok  # (a subset of A's columns: cond no larger)
    slack = REL * (flat + res) + ABS * np.sum(s * s, axis=(1, 2))
    none = flat - res + slack < JUMP_PRE * res / np.maximum(k - 6, 1) * (1 - REL)
    todo = np.flatnonzero(sure & ~none)
    if todo.size:  # (the smooth change beats a constant curvature: the hinges, stacked)
        none[todo] = _no_hinge(xy[todo], s[todo], quad[todo], coef_q[todo], mask[todo])
    return (k < MIN_POINTS) | low | sure & none


def _no_hinge(xy, s, quad, coef, mask):
    """(B,) whether ``find_jump`` surely finds no hinge along either axis of the slopes'
    gradient, for patches past its first test: the same gross contacts left out (each one's
    residual, and the next one's, clear of the cut-off by the margins), axes told apart
    (their eigenvalues ``GAP`` apart), and on each axis either its first test fails or the
    best cut's residual (every cut, each way, stably: a lower bound on the check's, whose
    ridge only adds to it) fails ``JUMP_RATIO`` or ``JUMP_F``, by the margins widened by how
    far the axes may turn between the two fits."""
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
        pre = lin - smooth + sl < JUMP_PRE * (smooth - sl) / dof * (1 - REL)
        best, ok = _best_hinge(u, v, y, keep, m, shared)
        lo, sure = best * (1 - REL) - slack, sure & (ok | pre)
        search = lo > JUMP_RATIO * (smooth * (1 + REL) + slack)
        search |= lin * (1 + REL) + slack - lo < JUMP_F * lo / dof * (1 - REL)
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
    k, (B, n) = MAX_LEFT_OUT, r.shape
    order = np.sort(np.where(mask, r, -1.0), axis=1)  # (the padding first)
    c = mask.sum(axis=1)
    b = np.arange(B)
    median = 0.5 * (order[b, n - c + (c - 1) // 2] + order[b, n - c + c // 2])
    cut = JUMP_GROSS * 1.4826 * median
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
    side = MIN_SIDE
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


def qr_fit(A, Y):
    """(Q (B, n, k), coefficients (B, k, m), residual sum of squares (B,), whether cond(A)
    is surely under ``QR_COND`` (by ||R||_F ||R^-1||_F)) of Y (B, n, m) fitted by A's
    (B, n, k) columns, by Householder QR: within about cond(A) eps of ``np.linalg.lstsq``'s."""
    Q, R = np.linalg.qr(A)
    d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    tiny = ~(d > 1e-12 * np.maximum(d.max(axis=-1, keepdims=True), 1e-300))
    Rinv = np.linalg.inv(R + np.eye(R.shape[-1]) * tiny[:, None, :])
    with np.errstate(over="ignore", invalid="ignore"):
        bound = np.sqrt(np.sum(R * R, axis=(1, 2)) * np.sum(Rinv * Rinv, axis=(1, 2)))
    QtY = np.swapaxes(Q, 1, 2) @ Y
    r = Y - Q @ QtY
    return Q, Rinv @ QtY, np.sum(r * r, axis=(1, 2)), ~tiny.any(axis=-1) & (bound < QR_COND)


def tangent_bases(m):
    """``tangent_basis`` of each unit row of m (B, 3), stacked: (t1, t2) (B, 3) each (as
    ``edges._basis`` and ``tilt._frame`` take them)."""
    ref = np.where(np.abs(m[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(m, ref)
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    return t1, np.cross(m, t1)


def solve_stacked(A, Y, rhs=None, max_cond=MAX_COND):
    """(the normal equations' solution (B, k, m) of A (B, n, k) against Y (B, n, m), or
    against ``rhs`` (B, k, m) as given; whether A's condition number is surely under
    ``MAX_COND``, so that it is within the margins of ``np.linalg.lstsq``'s) per patch.
    The bound: cond(G) <= |G|_F |G^-1|_F (G = A^T A), an inverse costing a fraction of G's
    eigenvalues; a patch it fails is left to the check."""
    G = A.transpose(0, 2, 1) @ A
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
