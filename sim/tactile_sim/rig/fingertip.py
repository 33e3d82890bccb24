"""EP1 through the F/T path: a spherical fingertip on a wrist force/moment sensor (§3.2, §3.3.3).

Intrinsic contact sensing as Tsujimura and Yabuta did (§3.3.3): the contact location on the
fingertip comes from force and moment, not from a tactile array.  Geometry, in the fingertip
frame of eq. 20 (centre at the origin, pole along +x, f(u, v) = R1 (cos u cos v,
-cos u sin v, sin u)): the sensor origin sits ``offset`` behind the centre, at (-offset, 0, 0),
with the same axes, so in the SENSOR frame the fingertip centre is (offset, 0, 0).

``fingertip_wrench`` gives the load on the finger for a contact at (u, v): the object pushes
along its outward normal, which is -g(u, v) (eq. 21) at the contact, plus an optional
tangential (friction) part inside the Coulomb cone.  Localising those loads with the host's
estimator is a study (``tactile_studies.ep1.ft_measure``), above the simulator.
"""

import numpy as np

__all__ = ["fingertip_point", "fingertip_uv", "fingertip_wrench"]


def fingertip_point(u, v, R1):
    """Eq. 20 in the fingertip frame, arrays (..., 3)."""
    u, v = np.asarray(u, float), np.asarray(v, float)
    return R1 * np.stack([np.cos(u) * np.cos(v), -np.cos(u) * np.sin(v), np.sin(u)], axis=-1)


def fingertip_uv(point, R1=None):
    """Inverse of eq. 20: (u, v) of points (..., 3) in the fingertip frame (radius from the
    point itself when R1 is None); u = asin(z/|p|) clamped, v = atan2(-y, x)."""
    p = np.asarray(point, float)
    rho = np.linalg.norm(p, axis=-1) if R1 is None else R1
    u = np.arcsin(np.clip(p[..., 2] / rho, -1.0, 1.0))
    v = np.arctan2(-p[..., 1], p[..., 0])
    return np.stack([u, v], axis=-1)


def _tangents(u, v):
    """Unit f_u and g x f_u at (u, v): an orthonormal tangent basis of the fingertip."""
    t1 = np.stack([-np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)], axis=-1)
    g = fingertip_point(u, v, 1.0)
    return t1, np.cross(g, t1)


def fingertip_wrench(u, v, R1, normal_force, offset, mu=0.0, phi=0.0):
    """Load on the finger (F, M about the sensor origin), sensor frame, for contacts at (u, v).

    ``mu`` and ``phi``: tangential force mu * f_n along cos(phi) t1 + sin(phi) t2.
    """
    u, v = np.asarray(u, float), np.asarray(v, float)
    g = fingertip_point(u, v, 1.0)
    fn = np.asarray(normal_force, float)[..., None]
    t1, t2 = _tangents(u, v)
    phi = np.asarray(phi, float)[..., None]
    F = fn * (-g + mu * (np.cos(phi) * t1 + np.sin(phi) * t2))
    arm = R1 * g + np.array([offset, 0.0, 0.0])
    return F, np.cross(arm, F)
