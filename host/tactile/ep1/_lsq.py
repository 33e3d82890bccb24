"""Least squares of eq. 33 for one EP1 point in plain floats (§3.2.3; used by ``estimate``).

NumPy costs about a microsecond per call on arrays this small, so one point is solved with
lists and ``math``: a few microseconds, stable (orthogonalisation, never the normal
equations of eq. 32), and equal to ``estimate_batch``'s Householder QR to round-off.
"""

import math
from math import ldexp
from operator import mul as _mul

__all__ = ["solve_point"]


def solve_point(X, Y, U, V, R1, u0, rank_tol, min_theta):
    """Least squares for (k1, k2, k3) of eq. 33 in plain floats (microseconds, no NumPy).

    ``X, Y, U, V``: lists of dtheta_x, dtheta_y, du, dv; R1 the finger radius and u0 its
    start parameter (eq. 20).  Scales the data by exact powers of two when they are near
    under/overflow (elsewhere nothing changes) and solves with ``_reduced_qr``.  Returns
    (k, |residual|, theta), or None if a pivot of A is at most ``rank_tol`` ||A||_F or the RMS
    rotation theta is below ``min_theta``.
    """
    m = len(X)
    norm_a = math.hypot(*X, *Y)  # sqrt(m) theta; ||A||_F = sqrt(2) norm_a
    theta = norm_a / math.sqrt(m)
    if not theta >= min_theta:
        return None
    if u0 != 0.0:
        c = math.cos(u0)
        V = [v * c for v in V]
    norm_b = math.hypot(*U, *V)
    ea = 0 if 1e-100 <= norm_a <= 1e100 else _exponent(norm_a, X, Y)
    eb = 0 if 1e-100 <= norm_b <= 1e100 else _exponent(norm_b, U, V)
    if ea:
        X, Y = [ldexp(x, ea) for x in X], [ldexp(y, ea) for y in Y]
        norm_a = math.hypot(*X, *Y)
    if eb:
        U, V = [ldexp(u, eb) for u in U], [ldexp(v, eb) for v in V]
    solved = _reduced_qr(X, Y, U, V, rank_tol * math.sqrt(2.0) * norm_a)
    if solved is None:
        return None
    k1, k2, k3, res = solved
    f, res = (_ldexp_clamped(R1, ea - eb), _ldexp_clamped(res, -eb)) if ea or eb else (R1, res)
    k = (k1 * f, k2 * f, k3 * f)
    if not abs(k[0]) <= 1e300 or not abs(k[1]) <= 1e300 or not abs(k[2]) <= 1e300:
        k = tuple(min(max(x, -1e300), 1e300) for x in k)  # absurd inputs stay finite
    return k, min(res * R1, 1e300), theta


def _reduced_qr(X, Y, U, V, tol):
    """Eq. 33 for b = (U, V) (R1 folded out): (k1, k2, k3, |residual|), or None if rank < 3.

    Per probe S a_i = b_i, a_i = (P_i, Q_i) = (-Y_i, X_i).  With the thin QR [P Q] = W T
    (T = [[t11, t12], [0, t22]]), eq. 33's 2m x 3 matrix A is diag(W, W) times the 4 x 3
    M with rows [t11 t12 0], [0 t22 0], [0 t11 t12], [0 0 t22]: the problem reduces exactly
    to M k = (W^T U, W^T V) plus the part of b outside range(W).  W^T b and that part come
    from modified Gram-Schmidt on [P Q U] and [P Q V] (backward stable for least squares,
    Bjorck 1967; q1 = -Y / t11 and q2 = w / t22 are kept unnormalised), M's QR from two
    Givens rotations.  A and M share their R factor, so the pivots tested against ``tol``
    (rank_tol ||A||_F) are the batch path's.
    """
    t11 = math.hypot(*Y)  # first pivot
    if not t11 > tol:
        return None
    t12 = -sum(map(_mul, Y, X)) / t11
    g = -t12 / t11
    w = [x - g * y for x, y in zip(X, Y)]  # noqa: B905 (equal lengths): X - t12 q1
    t22 = math.hypot(*w)
    rho = math.hypot(t11, t22)  # second pivot (>= t11, so never below tol)
    cs, sn = t22 / rho, t11 / rho
    t = cs * t12
    rho3 = math.hypot(t, t22)  # third pivot
    if not rho3 > tol:
        return None
    c11 = -sum(map(_mul, Y, U)) / t11  # q1 . U
    g = -c11 / t11
    U = [u - g * y for u, y in zip(U, Y)]  # noqa: B905
    c21 = sum(map(_mul, w, U)) / t22  # q2 . U
    g = c21 / t22
    U = [u - g * x for u, x in zip(U, w)]  # noqa: B905
    c12 = -sum(map(_mul, Y, V)) / t11
    g = -c12 / t11
    V = [v - g * y for v, y in zip(V, Y)]  # noqa: B905
    c22 = sum(map(_mul, w, V)) / t22
    g = c22 / t22
    V = [v - g * x for v, x in zip(V, w)]  # noqa: B905
    e = cs * c12 - sn * c21  # Givens on rows (0 t22 0 | c21), (0 t11 t12 | c12) ...
    k3 = (t * e + t22 * c22) / rho3 / rho3  # ... then on (0 0 t | e), (0 0 t22 | c22)
    k2 = (cs * c21 + sn * c12 - sn * t12 * k3) / rho
    k1 = (c11 - t12 * k2) / t11
    return k1, k2, k3, math.hypot(*U, *V, (t22 * e - t * c22) / rho3)


def _exponent(norm, *cols):
    """Power of two that brings ``norm`` (near under/overflow) to about 1; 0 for norm 0."""
    if norm == 0.0:
        return 0
    if norm == math.inf:  # hypot overflowed: the largest entry is finite
        norm = max(max(map(abs, c)) for c in cols)
    return -math.frexp(norm)[1]


def _ldexp_clamped(x, e):
    """x 2^e, at most 1e300 in magnitude (math.ldexp raises on overflow)."""
    if x == 0.0 or math.frexp(x)[1] + e < 997:
        return ldexp(x, e)
    return math.copysign(1e300, x)
