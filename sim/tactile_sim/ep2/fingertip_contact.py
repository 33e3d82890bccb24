"""A spherical fingertip against an EP2 object: the gap to it, and the first contact on an approach.

The objects are ``tactile_sim.ep2.objects``' (object frame, apex at the origin, the material
below the surface, normals toward the finger).  The exact kinds are solids with a closed-form
distance: the sphere a ball of radius R centred at (0, 0, -R), the pit the material outside
a ball centred at (0, 0, R), the cylinders about a line along the object's own v axis, the
plane z = 0.  The quadric height fields (saddle, quadric) take the nearest surface point by
Gauss-Newton from the point straight below (``scipy.optimize.least_squares``).

``gap(obj, c)`` is the signed distance of the point c from the surface (< 0 below it), with
the nearest surface point and the surface's unit normal there; a fingertip of radius r
centred at c clears the object when ``gap >= r``.  ``first_contact`` walks the fingertip's
centre along a ray by sphere tracing (the distance is 1-Lipschitz, so a step of the gap
never passes a contact) and brackets the crossing with Brent's method.
"""

import numpy as np
from scipy.optimize import brentq, least_squares

__all__ = ["Contact", "first_contact", "gap"]

TOL_M = 1e-5  # sphere tracing's smallest step (10 µm); the crossing is then found to 1e-12 m
MAX_STEPS = 5000  # a grazing approach creeps; bounded all the same


class Contact:
    """The first contact: along-ray distance ``s`` (m), the surface point ``point`` and the
    surface's unit ``normal`` there (object frame)."""

    __slots__ = ("s", "point", "normal")

    def __init__(self, s, point, normal):
        self.s, self.point, self.normal = float(s), point, normal


def _local(obj, c):
    """(u, v, z) of point c in the object's own axes (its rotation about z), and (cos, sin)."""
    cs, sn = np.cos(obj.rotation), np.sin(obj.rotation)
    x, y = c[0] - obj.centre[0], c[1] - obj.centre[1]
    return np.array([cs * x + sn * y, -sn * x + cs * y, c[2]]), cs, sn


def _world(obj, vec, cs, sn, point=False):
    """A local vector (or, with ``point``, a local point) back in the object frame."""
    x = cs * vec[0] - sn * vec[1]
    y = sn * vec[0] + cs * vec[1]
    if point:
        x, y = x + obj.centre[0], y + obj.centre[1]
    return np.array([x, y, vec[2]])


def _round(rel, radius, concave):
    """Signed distance, local nearest point offset and normal for a ball/cylinder surface of
    ``radius`` about the origin of ``rel`` (the point relative to the centre)."""
    rho = float(np.linalg.norm(rel))
    out = rel / rho if rho > 0.0 else np.array([0.0, 0.0, 1.0])
    if concave:  # material outside the ball: the normal points to its centre
        return radius - rho, radius * out, -out
    return rho - radius, radius * out, out


def gap(obj, c):
    """(d, point, normal): signed distance (m) of c (3,) from the surface, the nearest surface
    point and the unit normal there, all in the object frame."""
    c = np.asarray(c, float)
    ku, kv = obj.k
    if obj.kind == "plane" or (ku == 0 and kv == 0):
        return float(c[2]), np.array([c[0], c[1], 0.0]), np.array([0.0, 0.0, 1.0])
    if not obj.exact:
        return _quadric_gap(obj, c)
    loc, cs, sn = _local(obj, c)
    radius = 1.0 / abs(ku)
    concave = ku < 0
    centre_z = radius if concave else -radius
    if kv != 0:  # sphere or pit: a ball
        rel = loc - np.array([0.0, 0.0, centre_z])
        d, off, n = _round(rel, radius, concave)
        q = off + np.array([0.0, 0.0, centre_z])
    else:  # cylinder along v
        rel = np.array([loc[0], 0.0, loc[2] - centre_z])
        d, off, n = _round(rel, radius, concave)
        q = np.array([off[0], loc[1], off[2] + centre_z])
    return d, _world(obj, q, cs, sn, point=True), _world(obj, n, cs, sn)


def _quadric_gap(obj, c):
    """Nearest point of a height field z = h(x, y) by Gauss-Newton from below c."""

    def residual(xy):
        z = obj.eval(xy[0], xy[1])[0]
        return np.array([xy[0] - c[0], xy[1] - c[1], float(z) - c[2]])

    def jac(xy):
        _, zx, zy = obj.eval(xy[0], xy[1])
        return np.array([[1.0, 0.0], [0.0, 1.0], [float(zx), float(zy)]])

    fit = least_squares(residual, c[:2], jac=jac, method="lm", xtol=1e-14, ftol=1e-14)
    x, y = fit.x
    q = np.array([x, y, float(obj.height(x, y))])
    n = obj.normals(np.array([x]), np.array([y]))[0]
    below = c[2] < float(obj.height(c[0], c[1]))
    d = float(np.linalg.norm(c - q))
    return (-d if below else d), q, n


def first_contact(obj, start, direction, radius, travel):
    """The first contact of a fingertip of ``radius`` whose centre moves from ``start`` along
    the unit ``direction`` for at most ``travel`` (m): a ``Contact``, or None without one.
    The fingertip must clear the object at ``start`` (``ValueError`` otherwise)."""
    start, direction = np.asarray(start, float), np.asarray(direction, float)

    def clearance(s):
        return gap(obj, start + s * direction)[0] - radius

    s, g = 0.0, clearance(0.0)
    if g < 0.0:
        raise ValueError(f"the fingertip is {-g * 1e3:.3g} mm inside the object at the start")
    for _ in range(MAX_STEPS):
        if g == 0.0:
            break
        if s >= travel:
            return None
        nxt = min(s + max(g, TOL_M), travel)
        g_next = clearance(nxt)
        if g_next <= 0.0:
            s = brentq(clearance, s, nxt, xtol=1e-12)
            break
        s, g = nxt, g_next
    else:
        return None
    _, point, normal = gap(obj, start + s * direction)
    return Contact(s, point, normal)
