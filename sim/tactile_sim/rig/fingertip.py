"""EP1 through the F/T path: a spherical fingertip on a wrist force/moment sensor (§3.2, §3.3.3).

Intrinsic contact sensing as Tsujimura and Yabuta did (§3.3.3): the contact location on the
fingertip comes from force and moment, not from a tactile array.  Geometry, in the fingertip
frame of eq. 20 (centre at the origin, pole along +x, f(u, v) = R1 (cos u cos v,
-cos u sin v, sin u)): the sensor origin sits ``offset`` behind the centre, at (-offset, 0, 0),
with the same axes, so in the SENSOR frame the fingertip centre is (offset, 0, 0).

``fingertip_wrench`` gives the load on the finger for a contact at (u, v): the object pushes
along its outward normal, which is -g(u, v) (eq. 21) at the contact, plus an optional
tangential (friction) part inside the Coulomb cone.  ``measure_ft`` turns the EP1
simulator's true probes (``tactile_sim.ep1.probes.Probes``) into measured rows
(dtheta_x, dtheta_y, du, dv), the same layout as ``probes.measure``, with du, dv from the
wrench localised by ``tactile.localize.sphere_contact`` at the start and end of each probe.
"""

import numpy as np

from tactile_sim.rig.sensor import SIGMA_F, SIGMA_M, add_noise

__all__ = ["fingertip_point", "fingertip_uv", "fingertip_wrench", "measure_ft"]


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


def measure_ft(
    probes,
    R1,
    normal_force=1.5,
    offset=0.05,
    mu=0.0,
    sigma_f=SIGMA_F,
    sigma_m=SIGMA_M,
    sigma_theta=0.0,
    threshold=0.0,
    rng=None,
    method="moment",
):
    """Measured (dtheta_x, dtheta_y, du, dv) rows (..., n, 4) and a usable mask (..., n).

    Each probe's start and end contacts are felt through ``fingertip_wrench`` (friction of
    ratio ``mu`` in a random tangent direction when rng is given), noised per axis and
    localised on the hemisphere; a probe is usable when both ends localise ('ok' or
    'near_miss').  Angle noise as in ``probes.measure``.  ``method``: "moment" (line of
    action, valid with friction) or "force" (frictionless: the direction of F only).
    """
    from tactile.localize.sphere import sphere_contact, sphere_contact_frictionless

    if method not in ("moment", "force"):
        raise ValueError(f"unknown method {method!r}; choose 'moment' or 'force'")
    centre, pole = (offset, 0.0, 0.0), (1.0, 0.0, 0.0)

    noisy = rng is not None
    ends = []
    for p in (probes.p_start, probes.p_end):
        phi = rng.uniform(0.0, 2 * np.pi, p.shape[:-1]) if noisy and mu else 0.0
        F, M = fingertip_wrench(p[..., 0], p[..., 1], R1, normal_force, offset, mu, phi)
        F, M = add_noise(F, M, rng, sigma_f, sigma_m)
        if method == "moment":
            c = sphere_contact(F, M, centre, R1, threshold, axis=pole)
        else:
            c = sphere_contact_frictionless(F, centre, R1, threshold, axis=pole)
        ends.append((fingertip_uv(c.point - np.array([offset, 0.0, 0.0]), R1), c.usable))
    (uv0, ok0), (uv1, ok1) = ends
    dth = probes.dtheta
    if sigma_theta > 0.0 and noisy:
        dth = dth + rng.normal(0.0, sigma_theta, dth.shape[:-1])[..., None] * probes.axis
    rows = np.concatenate([dth, uv1 - uv0], axis=-1)
    usable = ok0 & ok1
    return np.where(usable[..., None], rows, 0.0), usable
