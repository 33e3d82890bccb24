"""Forward contact model: where the wheel touches an object, and the wrench it feels.

``wheel_touch``: the deepest point of the rim circle (mid-plane, radius L4 about the wheel
centre) in the object, found by sampling the visible arc and refining with a bounded scalar
minimiser; depth = -min d.  The force acts along the object's outward normal there.

``contact_wrench``: the load on the probe (ATI's convention) for a contact at p with outward
normal n (object's, toward the probe):

    F = f_n n + mu f_n s,     M = (p - O) x F,

where s is the unit direction of the tangential friction: opposite the probe's sliding
velocity relative to the object (Coulomb, sliding); mu = 0 is frictionless.
"""

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["wheel_touch", "contact_wrench", "friction_direction"]


def _rim(R, t, centre, radius, theta):
    local = centre + radius * np.stack([np.cos(theta), np.sin(theta), 0.0 * theta], axis=-1)
    return local @ R.T + t


def wheel_touch(obj, R, t, centre, radius, arc_limit=np.pi, samples=721):
    """Deepest rim point of the wheel in ``obj`` for sensor pose (R, t).

    Returns (point_world, normal_world, depth, theta) with theta the contact angle in the
    sensor frame; depth <= 0 means no contact (the gap is -depth).
    """
    theta = np.linspace(-arc_limit, arc_limit, samples)
    d, _ = obj.distance(_rim(R, t, centre, radius, theta))
    k = int(np.argmin(d))
    step = theta[1] - theta[0]
    lo, hi = max(theta[k] - step, -arc_limit), min(theta[k] + step, arc_limit)

    def depth_at(a):
        return float(obj.distance(_rim(R, t, centre, radius, np.array(a)))[0])

    res = minimize_scalar(depth_at, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
    th = float(res.x) if res.fun <= d[k] else float(theta[k])
    # Polish: at the deepest rim point the rim's radial direction is minus the horizontal
    # part of the object's normal (in the sensor frame); a fixed-point step makes the
    # returned (p, n) consistent to round-off instead of the minimiser's sqrt(eps).
    for _ in range(30):
        m = -(R.T @ obj.distance(_rim(R, t, centre, radius, np.array(th)))[1])
        if np.hypot(m[0], m[1]) < 1e-9:
            break
        new = float(np.arctan2(m[1], m[0]))
        if abs(new) > arc_limit or abs(new - th) > step:
            break
        done = abs(new - th) < 1e-15
        th = new
        if done:
            break
    p = _rim(R, t, centre, radius, np.array(th))
    dist, n = obj.distance(p)
    return p, n, -float(dist), th


def friction_direction(normal, velocity):
    """Unit tangential friction direction: minus the tangential part of the probe's velocity
    relative to the object; zero if the probe moves along the normal."""
    n = np.asarray(normal, float)
    v = np.asarray(velocity, float)
    vt = v - np.einsum("...i,...i->...", v, n)[..., None] * n
    norm = np.linalg.norm(vt, axis=-1, keepdims=True)
    return -vt / np.where(norm > 1e-15, norm, np.inf)


def contact_wrench(point, normal, normal_force, mu=0.0, slip=None, origin=(0.0, 0.0, 0.0)):
    """Load on the probe (F, M about ``origin``) for contacts (..., 3), any frame."""
    n = np.asarray(normal, float)
    F = np.asarray(normal_force, float)[..., None] * n
    if mu and slip is not None:
        F = F + mu * np.asarray(normal_force, float)[..., None] * np.asarray(slip, float)
    M = np.cross(np.asarray(point, float) - np.asarray(origin, float), F)
    return F, M
