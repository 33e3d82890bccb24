"""A curvature jump: a plane joined tangentially to a curved surface, inside one patch.

The normals' slope s over the tangent plane changes smoothly on a smooth surface; across
a tangent join it is constant on one side (the plane) and turns linearly on the other.
``find_jump`` fits, along each axis u of the slopes' gradient, a hinge (s constant on one
side of u0, linear on the other) against a smooth change (s quadratic in u) and a constant
curvature (s linear in u), after leaving out up to ``MAX_LEFT_OUT`` gross contacts.
``check`` makes a fitted label (not ``plane``) ``uncertain`` across such a jump, with a
warning placing it; S, k1, k2 and their intervals stay the smooth fit's.
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
