"""Implicit surfaces F(p) = 0 and their true curvature, by a route of their own (§2.2, §2.4).

Each ``Surface`` gives F, its gradient and its Hessian in closed form, vectorised over (m, 3)
points in the surface's own (local) coordinates.  F increases toward the finger, so the
outward normal grad F / |grad F| points from the object to the finger.  Kinds:

- ``sphere`` (sign, R): F = sign (|p|^2 - R^2) / (2R); sign +1 touched from outside
  (k1 = k2 = +1/R), -1 a pit (the inside of a sphere, k = -1/R).
- ``cylinder`` (sign, R): the same about the z axis (k = sign/R, 0).
- ``ellipsoid`` (a, b, c): F = (x^2/a^2 + y^2/b^2 + z^2/c^2 - 1) / 2.
- ``torus`` (R, r): F = (rho - R)^2 + z^2 - r^2, rho = sqrt(x^2 + y^2): outer equator
  k = 1/r, 1/(R + r); inner equator (a saddle) k = 1/r, -1/(R - r).
- ``height`` (C): F = z - h(x, y), h = sum C[i, j] x^i y^j (degree <= 4), touched from +z.

Truth (``principal``): at a point on F = 0 the shape operator is the Hessian of F projected
on the tangent plane over |grad F|, W = T^T Hess(F) T / |grad F| (T an orthonormal tangent
basis), whose eigenvalues are k1 >= k2, positive where the surface is convex toward the
finger (a sphere touched from outside has +1/R; §2.2's sign as in ``tactile.ep2``).  With
them S = (2/pi) atan2(k1 + k2, k1 - k2) (§2.4).  Nothing here uses
``tactile.ep2.geometry`` or a height-field parametrisation: it checks them.
"""

from dataclasses import dataclass

import numpy as np
from numpy.polynomial import polynomial as P

KINDS = ("sphere", "cylinder", "ellipsoid", "torus", "height")
FLAT_KL = 1e-12  # |k|max L at or below this: S is undefined (None)


@dataclass(frozen=True)
class Surface:
    """An implicit surface in its own coordinates: ``kind`` and its parameters (a tuple;
    for ``height`` the 5 x 5 coefficient matrix as nested tuples)."""

    kind: str
    params: tuple

    def F(self, p):
        """F at (m, 3) points."""
        x, y, z = np.asarray(p, float).T
        k, a = self.kind, self.params
        if k == "sphere":
            return a[0] * (x * x + y * y + z * z - a[1] ** 2) / (2 * a[1])
        if k == "cylinder":
            return a[0] * (x * x + y * y - a[1] ** 2) / (2 * a[1])
        if k == "ellipsoid":
            return 0.5 * ((x / a[0]) ** 2 + (y / a[1]) ** 2 + (z / a[2]) ** 2 - 1.0)
        if k == "torus":
            return (np.hypot(x, y) - a[0]) ** 2 + z * z - a[1] ** 2
        return z - P.polyval2d(x, y, np.asarray(a, float))

    def grad(self, p):
        """grad F at (m, 3) points: (m, 3)."""
        p = np.asarray(p, float)
        x, y, z = p.T
        k, a = self.kind, self.params
        if k == "sphere":
            return a[0] * p / a[1]
        if k == "cylinder":
            return a[0] * np.column_stack([x, y, 0 * z]) / a[1]
        if k == "ellipsoid":
            return p / np.asarray(a, float) ** 2
        if k == "torus":
            rho = np.maximum(np.hypot(x, y), 1e-300)  # the axis is not on the surface
            f = 2 * (rho - a[0]) / rho
            return np.column_stack([f * x, f * y, 2 * z])
        c = np.asarray(a, float)
        hx = P.polyval2d(x, y, P.polyder(c, axis=0))
        hy = P.polyval2d(x, y, P.polyder(c, axis=1))
        return np.column_stack([-hx, -hy, np.ones_like(z)])

    def hess(self, p):
        """Hessian of F at (m, 3) points: (m, 3, 3)."""
        p = np.asarray(p, float)
        x, y, z = p.T
        k, a = self.kind, self.params
        out = np.zeros((len(p), 3, 3))
        if k == "sphere":
            out[:] = a[0] * np.eye(3) / a[1]
        elif k == "cylinder":
            out[:] = a[0] * np.diag([1.0, 1.0, 0.0]) / a[1]
        elif k == "ellipsoid":
            out[:] = np.diag(1.0 / np.asarray(a, float) ** 2)
        elif k == "torus":
            rho = np.maximum(np.hypot(x, y), 1e-300)
            g = (rho - a[0]) / rho**3
            out[:, 0, 0] = 2 * (x * x / rho**2 + g * y * y)
            out[:, 1, 1] = 2 * (y * y / rho**2 + g * x * x)
            out[:, 0, 1] = out[:, 1, 0] = 2 * x * y * (1.0 / rho**2 - g)
            out[:, 2, 2] = 2.0
        else:
            c = np.asarray(a, float)
            cx = P.polyder(c, axis=0)
            out[:, 0, 0] = -P.polyval2d(x, y, P.polyder(cx, axis=0))
            out[:, 0, 1] = out[:, 1, 0] = -P.polyval2d(x, y, P.polyder(cx, axis=1))
            out[:, 1, 1] = -P.polyval2d(x, y, P.polyder(c, axis=1, m=2))
        return out


def height(coef):
    """A ``height`` surface from a coefficient array C[i, j] of x^i y^j (padded to 5 x 5)."""
    c = np.zeros((5, 5))
    coef = np.asarray(coef, float)
    c[: coef.shape[0], : coef.shape[1]] = coef
    return Surface("height", tuple(tuple(float(v) for v in row) for row in c))


def tangent_basis(n):
    """(m, 3, 2) orthonormal tangent vectors of unit normals (m, 3)."""
    n = np.asarray(n, float)
    ref = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = ref - np.sum(ref * n, axis=1, keepdims=True) * n
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return np.stack([t1, np.cross(n, t1)], axis=-1)


def normals(surf, p):
    """Outward unit normals grad F / |grad F| at (m, 3) points."""
    g = surf.grad(p)
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def principal(surf, p):
    """(k1, k2) arrays, k1 >= k2, at (m, 3) points on the surface (module docstring).

    The 2 x 2 symmetric W = [[a, b], [b, c]] has k = m +/- sqrt(((a - c)/2)^2 + b^2),
    m = (a + c)/2: no k1 - k2 division, exact at umbilics."""
    p = np.atleast_2d(np.asarray(p, float))
    g = surf.grad(p)
    gn = np.linalg.norm(g, axis=1)
    T = tangent_basis(g / gn[:, None])
    W = np.einsum("mia,mij,mjb->mab", T, surf.hess(p), T) / gn[:, None, None]
    a, b, c = W[:, 0, 0], 0.5 * (W[:, 0, 1] + W[:, 1, 0]), W[:, 1, 1]
    mid, half = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
    return mid + half, mid - half


def shape_index(k1, k2, size=1.0):
    """S = (2/pi) atan2(k1 + k2, k1 - k2) (§2.4), None where max|k| size <= ``FLAT_KL``."""
    if max(abs(k1), abs(k2)) * size <= FLAT_KL:
        return None
    return float(2.0 / np.pi * np.arctan2(k1 + k2, k1 - k2))


def line_root(surf, origin, direction, scale, iters=80):
    """(points (m, 3), ok (m,)): where origin + s direction meets F = 0, by Newton on s from
    s = 0 with steps clipped to ``scale`` / 2 (the nearest root along the line for lines that
    start within a patch of the surface).  ``ok`` is False where the line has no root there
    (a slope of F along the line near 0, or no convergence within |s| <= 4 ``scale``)."""
    o = np.atleast_2d(np.asarray(origin, float))
    d = np.atleast_2d(np.asarray(direction, float))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    s = np.zeros(len(o))
    done = np.zeros(len(o), bool)
    tol = 1e-14 * scale + 4e-16 * np.max(np.abs(o), axis=1)  # round-off of the coordinates
    for _ in range(iters):
        q = o + s[:, None] * d
        f, slope = surf.F(q), np.sum(surf.grad(q) * d, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(np.abs(slope) > 1e-12, -f / slope, np.inf)
        step = np.clip(step, -0.5 * scale, 0.5 * scale)
        small = np.abs(step) <= tol
        s = np.where(done, s, s + step)
        done |= small
        if done.all():
            break
    q = o + s[:, None] * d
    g = surf.grad(q)
    dist = np.abs(surf.F(q)) / np.linalg.norm(g, axis=1)
    ok = done & (np.abs(s) <= 4 * scale) & (dist <= 1e-10 * scale + 1e4 * tol)
    return q, ok


def truth_along(surf, origin, direction, size):
    """Truth where lines meet the surface: dict of arrays ``k1``, ``k2``, ``point`` and
    ``ok``, and the list ``S`` (None where flat or not reached); ``size`` the patch size."""
    q, ok = line_root(surf, origin, direction, size)
    k1, k2 = principal(surf, q)
    S = [shape_index(a, b, size) if good else None for a, b, good in zip(k1, k2, ok)]
    return {"k1": k1, "k2": k2, "S": S, "point": q, "ok": ok}
