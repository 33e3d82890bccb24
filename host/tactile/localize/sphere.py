"""Contact on a spherical fingertip from force AND moment (§5.1.1 with friction; §3.3.3).

The contact lies where the line of action of the force (``line.line_of_action``) meets the
fingertip sphere |p - c| = r.  Of the two intersections, the contact is the one where the
force presses INTO the fingertip: going along F, the first one (entry), where
(p - c) . F <= 0.  Friction only tilts F inside its cone; the point, and so the normal
n = (c - p)/r (object's outward normal, toward the fingertip centre), stay exact.

When noise makes the line miss the sphere by d > 0, the point is the sphere's point closest
to the line and the row is flagged ``near_miss`` (d <= tol) or ``miss``.
"""

import numpy as np

from tactile.localize.contact import (
    MISS,
    NEAR_MISS,
    NO_CONTACT,
    OFF_PROBE,
    OK,
    Contact,
)
from tactile.localize.line import entry_root, line_of_action

__all__ = ["sphere_contact", "sphere_contact_frictionless"]


def sphere_contact(
    force,
    moment,
    centre,
    radius,
    threshold=0.0,
    tol=None,
    axis=None,
    half_angle=0.5 * np.pi,
    origin=(0.0, 0.0, 0.0),
):
    """Locate contacts on a sphere (centre ``c``, radius ``r``) from readings (..., 3).

    ``force`` is the force the object applies to the probe and ``moment`` its moment about
    the sensor ``origin``, both in the sensor frame (ATI's convention: the load on the tool).
    Readings with |F| <= ``threshold`` are ``no_contact``.  ``tol`` (default 0.1 r) splits
    ``near_miss`` from ``miss``.  With ``axis`` (unit pole of a hemispherical fingertip) a
    point more than ``half_angle`` from the pole is ``off_probe``.
    """
    c = np.asarray(centre, dtype=float)
    r = float(radius)
    tol = 0.1 * r if tol is None else float(tol)
    p0, u, fnorm, _ = line_of_action(force, moment, origin)
    d = p0 - c
    b = np.einsum("...i,...i->...", d, u)
    t, disc = entry_root(1.0, b, np.einsum("...i,...i->...", d, d) - r * r)
    q = p0 + t[..., None] * u  # entry point, or the line's closest approach to c
    radial = q - c
    dist = np.linalg.norm(radial, axis=-1)
    hit = disc >= 0.0
    # On a miss, project the closest approach onto the sphere (dist > r > 0 there).
    scale = np.where(hit, 1.0, r / np.where(dist > 0.0, dist, 1.0))
    point = c + radial * scale[..., None]
    normal = -(point - c) / r
    residual = np.where(hit, 0.0, np.maximum(dist - r, 0.0))
    status = np.where(hit, OK, np.where(residual <= tol, NEAR_MISS, MISS))
    if axis is not None:
        pole = np.asarray(axis, dtype=float)
        pole = pole / np.linalg.norm(pole)
        off = -np.einsum("...i,i->...", normal, pole) < np.cos(half_angle) - 1e-12
        status = np.where(off & (status != MISS), OFF_PROBE, status)
    return _finish(point, normal, status, residual, force, fnorm, threshold)


def sphere_contact_frictionless(
    force, centre, radius, threshold=0.0, axis=None, half_angle=0.5 * np.pi
):
    """Frictionless contact on a sphere from the force alone (the sphere analogue of eq. 61).

    Without friction F is normal, so it passes through the centre: p = c - r F/|F| and the
    object's normal is F/|F|.  Far less sensitive to noise than the line of action (no
    moment, no lever arm), but biased by r atan(mu) along the surface under friction.
    """
    c = np.asarray(centre, dtype=float)
    F = np.asarray(force, dtype=float)
    fnorm = np.linalg.norm(F, axis=-1)
    u = F / np.where(fnorm > 0.0, fnorm, 1.0)[..., None]
    status = np.full(fnorm.shape, OK)
    if axis is not None:
        pole = np.asarray(axis, dtype=float)
        pole = pole / np.linalg.norm(pole)
        off = -np.einsum("...i,i->...", u, pole) < np.cos(half_angle) - 1e-12
        status = np.where(off, OFF_PROBE, status)
    zero = np.zeros(fnorm.shape)
    return _finish(c - float(radius) * u, u, status, zero, F, fnorm, threshold)


def _finish(point, normal, status, residual, force, fnorm, threshold, gate_norm=None):
    """Normal force and friction angle; zero the rows below the gate (shared with wheel)."""
    F = np.asarray(force, dtype=float)
    fn = np.einsum("...i,...i->...", F, normal)
    ft = np.linalg.norm(F - fn[..., None] * normal, axis=-1)
    friction = np.arctan2(ft, np.maximum(fn, 0.0))
    gate = fnorm if gate_norm is None else gate_norm
    off = ~(gate > threshold) | ~(fnorm > 0.0)
    zero = np.zeros_like(fnorm)
    return Contact(
        point=np.where(off[..., None], 0.0, point),
        normal=np.where(off[..., None], 0.0, normal),
        status=np.where(off, NO_CONTACT, status).astype(np.int8),
        residual=np.where(off, zero, residual),
        friction=np.where(off, zero, friction),
        force=np.where(off, zero, fn),
    )
