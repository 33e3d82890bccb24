"""True curvature of a sim height field AT THE PATCH CENTRE (the EP2 estimand).

The patch frame is the library's (``tactile.ep2.geometry.frame_from_contacts``:
origin at the centroid, z = mean unit normal); the patch centre is the middle of
the contacts' bounding box in patch-frame x, y.  The true surface point is where
the patch-frame z line through that centre meets the surface (1-D Newton root).
There, k1 >= k2 come from the analytic second derivatives of h(x, y) through the
first and second fundamental forms (§2.2): with p, q = h_x, h_y and W^2 = 1 + p^2 + q^2,

    K = (h_xx h_yy - h_xy^2) / W^4,
    H = -((1 + q^2) h_xx - 2 p q h_xy + (1 + p^2) h_yy) / (2 W^3),
    k = H +/- sqrt(H^2 - K)     (H^2 - K in a cancellation-free form, ``curvatures``),

signed positive where the surface is convex toward +z, the finger's side (a cap
z = -(x^2 + y^2)/(2R) has k1 = k2 = +1/R).  This route shares nothing with
``tactile.ep2.geometry`` (Cholesky of I) on purpose: it checks it.  It does share
the estimator's patch frame, which defines where the estimand is: so it is a study
(application layer), not part of the simulator.
"""

import numpy as np

from tactile.ep2.geometry import frame_from_contacts


def hessian(obj, x, y):
    """(h_xx, h_xy, h_yy) of a ``tactile_sim.ep2.objects.HeightField``, world frame, exactly."""
    c, s = np.cos(obj.rotation), np.sin(obj.rotation)
    dx, dy = x - obj.centre[0], y - obj.centre[1]
    u, v = c * dx + s * dy, -s * dx + c * dy
    huu, huv, hvv = _local_hessian(obj, u, v)
    # chain rule through u = c dx + s dy, v = -s dx + c dy (the slope term is linear)
    hxx = c * c * huu - 2 * c * s * huv + s * s * hvv
    hxy = c * s * (huu - hvv) + (c * c - s * s) * huv
    hyy = s * s * huu + 2 * c * s * huv + c * c * hvv
    return hxx, hxy, hyy


def _local_hessian(obj, u, v):
    """Second derivatives along the object's own axes (see ``tactile_sim.ep2.objects._profile``)."""
    ku, kv = obj.k
    if obj.kind == "plane":
        return 0.0, 0.0, 0.0
    if obj.exact and ku != 0 and kv != 0:  # cap z = sign (sqrt(R^2 - r^2) - R)
        big, sign = 1.0 / abs(ku), np.sign(ku)
        q3 = (big * big - u * u - v * v) ** 1.5
        return (
            -sign * (big * big - v * v) / q3,
            -sign * u * v / q3,
            -sign * (big * big - u * u) / q3,
        )
    if obj.exact and ku != 0:  # cylinder along v
        big, sign = 1.0 / abs(ku), np.sign(ku)
        return -sign * big * big / (big * big - u * u) ** 1.5, 0.0, 0.0
    return -ku, 0.0, -kv  # quadric z = -(ku u^2 + kv v^2) / 2


def curvatures(p, q, hxx, hxy, hyy):
    """(k1, k2), k1 >= k2, from the fundamental forms of z = h(x, y) (module docstring).

    H^2 - K is formed as N / (4 W^6), N = (E g - G e)^2 + 4 (E f - F e)(G f - F g)
    (E, F, G = 1 + p^2, p q, 1 + q^2; e, f, g = h_xx, h_xy, h_yy), which vanishes
    without cancellation at an umbilic, where II is proportional to I.
    """
    big_e, big_f, big_g = 1.0 + p * p, p * q, 1.0 + q * q
    w2 = big_e * big_g - big_f * big_f  # = 1 + p^2 + q^2
    mean = -(big_g * hxx - 2 * big_f * hxy + big_e * hyy) / (2 * w2**1.5)
    n = (big_e * hyy - big_g * hxx) ** 2 + 4 * (big_e * hxy - big_f * hxx) * (
        big_g * hxy - big_f * hyy
    )
    root = np.sqrt(max(n, 0.0)) / (2 * w2**1.5)
    return mean + root, mean - root


def shape_index(k1, k2):
    """Koenderink's S = (2/pi) atan2(k1 + k2, k1 - k2) (§2.4, eq. 17 with our sign)."""
    return float(2.0 / np.pi * np.arctan2(k1 + k2, k1 - k2))


def patch_centre(points, normals):
    """(frame, centre_xy): the library's patch frame and its bounding-box centre."""
    n = np.asarray(normals, float)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    frame = frame_from_contacts(np.asarray(points, float), n)
    q = frame.to_patch(points)[:, :2]
    return frame, 0.5 * (q.min(axis=0) + q.max(axis=0))


def surface_point(obj, start, direction, scale=1.0, iters=60):
    """(x, y, z) where start + t direction meets z = h(x, y) (object frame; damped Newton)."""
    t = 0.0
    for _ in range(iters):
        x, y, z = start + t * direction
        h, hx, hy = (float(v) for v in obj.eval(x, y))
        f = z - h
        slope = direction[2] - hx * direction[0] - hy * direction[1]
        if abs(f) <= 1e-13 * scale:
            return np.array([x, y, h])
        if not abs(slope) > 1e-9:
            break
        step = -f / slope
        t = t + np.clip(step, -0.5 * scale, 0.5 * scale)
    raise ValueError("the patch-centre normal line does not meet the surface (no root)")


def at_centre(obj, points, normals, unit=1.0, tilt=None):
    """Truth at the patch centre: k1, k2 (1/unit), S (None on a plane), radius, the surface
    point ``xyz`` (object frame), the patch-frame ``centre`` and ``size`` (larger side).

    ``points`` are as measured (length unit = base unit x ``unit``); ``tilt`` is the
    3 x 3 rotation that took object coordinates to the measured frame (None: identity).
    """
    pts = np.asarray(points, float) / unit
    frame, (cx, cy) = patch_centre(pts, normals)
    rot = np.eye(3) if tilt is None else np.asarray(tilt, float)
    start = frame.to_world(np.array([cx, cy, 0.0])) @ rot
    direction = frame.rot[2] @ rot
    size = float(np.max(np.ptp(frame.to_patch(pts)[:, :2], axis=0)))
    x, y, _ = surface_point(obj, start, direction, max(size, 1e-12))
    _, p, q = (float(v) for v in obj.eval(x, y))
    k1, k2 = curvatures(p, q, *(float(v) for v in hessian(obj, x, y)))
    k1, k2 = k1 / unit, k2 / unit
    kmax = max(abs(k1), abs(k2))
    flat = kmax * size * unit <= 1e-12
    return {
        "k1": float(k1),
        "k2": float(k2),
        "S": None if flat else shape_index(k1, k2),
        "radius": None if flat else float(1.0 / kmax),
        "xyz": (float(x) * unit, float(y) * unit, float(obj.height(x, y)) * unit),
        "centre": (float(cx) * unit, float(cy) * unit),
        "size": size * unit,
    }
