"""Contact on the two probes: a spherical fingertip, and the wheel of ch. 5.

**The spherical fingertip**, from force AND moment (§5.1.1 with friction; §3.3.3).

The contact lies where the line of action of the force (``contact.line_of_action``) meets the
fingertip sphere |p - c| = r.  Of the two intersections, the contact is the one where the
force presses INTO the fingertip: going along F, the first one (entry), where
(p - c) . F <= 0.  Friction only tilts F inside its cone; the point, and so the normal
n = (c - p)/r (object's outward normal, toward the fingertip centre), stay exact.

When noise makes the line miss the sphere by d > 0, the point is the sphere's point closest
to the line and the row is flagged ``near_miss`` (d <= tol) or ``miss``.

**The circular probe ("wheel")** of §5.1.1, fig. 37.

Geometry, in the sensor frame: the probe shaft runs along +x from the sensor origin to the
wheel centre ``c`` (= (L3, 0, 0) on the ch. 5 rig, fig. 38); the wheel is a disc of radius
``L4`` in the x-y plane, its rim a cylinder of half-thickness ``w`` about the z axis through c.
The shaft joins the rim at angle pi, so only contact angles |theta| <= ``arc_limit`` are
on the probe.

Two localisers:

``wheel_contact`` (frictionless, force only; eqs. 60-61).  The force is normal to the rim, so
its direction gives the contact angle.  With F the force ON THE PROBE (our convention, ATI's),
F points from the contact toward the centre, hence

    theta = atan2(-fy, -fx),   p = c + L4 (cos theta, sin theta, 0),
    normal (object's, toward the probe) = -(cos theta, sin theta, 0) = n(theta) of eq. 60.

The thesis writes theta = atan2(fy, fx) (eq. 61): that is the same angle if fx, fy are the
force the probe applies TO THE OBJECT (``convention="object"``), and it is what eq. 62 needs
(L4 cos(q1 + q2 + q3 + theta) places the point AT angle theta).  With the load convention the
literal eq. 61 puts the point diametrically opposite.  z is not determined (§5.1.1); the
point is given on the wheel's mid-plane.

``rim_contact`` (with friction; force and moment).  The line of action meets the rim
cylinder: in x-y, |p0 + t u - c|_xy = L4, entry root; z follows from the line, so the
moment also resolves the height on the rim that eq. 61 cannot.
"""

import numpy as np

from tactile.localize.contact import (
    DEGENERATE,
    MISS,
    NEAR_MISS,
    NO_CONTACT,
    OFF_PROBE,
    OK,
    Contact,
    entry_root,
    line_of_action,
)

__all__ = [
    "sphere_contact",
    "sphere_contact_frictionless",
    "wheel_theta",
    "wheel_contact",
    "rim_contact",
    "CONVENTIONS",
]


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


CONVENTIONS = ("probe", "object")


def wheel_theta(force, convention="probe"):
    """Contact angle on the wheel from fx, fy (eq. 61), in (-pi, pi].

    ``convention="probe"``: ``force`` is the load on the probe (ATI); ``"object"``: the force
    the probe applies to the object, for which this is literally eq. 61.
    """
    if convention not in CONVENTIONS:
        raise ValueError(f"unknown convention {convention!r}; choose from {CONVENTIONS}")
    F = np.asarray(force, dtype=float)
    sign = -1.0 if convention == "probe" else 1.0
    return np.arctan2(sign * F[..., 1], sign * F[..., 0])


def wheel_contact(force, centre, radius, threshold=0.0, arc_limit=np.pi, convention="probe"):
    """Frictionless contact point and normal on the wheel from the force alone (eqs. 60-61).

    Gate: |F_xy| > ``threshold`` (§5.1: "a force in the x-y plane with magnitude greater
    than 5 units").  Returns a ``Contact`` (normal = object's, toward the probe) and theta.
    """
    F = np.asarray(force, dtype=float)
    theta = wheel_theta(F, convention)
    c = np.asarray(centre, dtype=float)
    radial = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=-1)
    point = c + radius * radial
    status = np.where(np.abs(theta) <= arc_limit, OK, OFF_PROBE)
    load = F if convention == "probe" else -F
    fxy = np.hypot(F[..., 0], F[..., 1])
    contact = _finish(
        point,
        -radial,
        status,
        np.zeros_like(theta),
        load,
        np.linalg.norm(F, axis=-1),
        threshold,
        gate_norm=fxy,
    )
    return contact, np.where(contact.status == NO_CONTACT, 0.0, theta)


def rim_contact(
    force,
    moment,
    centre,
    radius,
    half_thickness=np.inf,
    threshold=0.0,
    tol=None,
    arc_limit=np.pi,
    origin=(0.0, 0.0, 0.0),
):
    """Contact on the wheel's rim from force and moment, valid with friction (§5.1.1).

    ``force``: load on the probe; ``moment``: about the sensor ``origin``.  Gate on |F_xy|.
    A point more than ``half_thickness`` from the wheel's mid-plane, or beyond ``arc_limit``,
    is ``off_probe``; a force (nearly) along the wheel axis is ``degenerate``.
    Returns a ``Contact`` and theta (contact angle about the wheel centre from +x).
    """
    c = np.asarray(centre, dtype=float)
    r = float(radius)
    tol = 0.1 * r if tol is None else float(tol)
    F = np.asarray(force, dtype=float)
    p0, u, fnorm, _ = line_of_action(F, moment, origin)
    d = (p0 - c)[..., :2]
    uxy = u[..., :2]
    a = np.einsum("...i,...i->...", uxy, uxy)
    flat = a < 1e-12
    a_safe = np.where(flat, 1.0, a)
    b = np.einsum("...i,...i->...", d, uxy)
    t, disc = entry_root(a_safe, b, np.einsum("...i,...i->...", d, d) - r * r)
    q = p0 + t[..., None] * u
    radial = (q - c)[..., :2]
    dist = np.hypot(radial[..., 0], radial[..., 1])
    hit = disc >= 0.0
    theta = np.arctan2(radial[..., 1], radial[..., 0])
    ring = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=-1)
    point = np.concatenate([c[:2] + r * ring[..., :2], q[..., 2:]], axis=-1)
    residual = np.where(hit, 0.0, np.maximum(dist - r, 0.0))
    status = np.where(hit, OK, np.where(residual <= tol, NEAR_MISS, MISS))
    off = (np.abs(q[..., 2] - c[2]) > half_thickness) | (np.abs(theta) > arc_limit)
    status = np.where(off & (status != MISS), OFF_PROBE, status)
    status = np.where(flat, DEGENERATE, status)
    fxy = np.hypot(F[..., 0], F[..., 1])
    contact = _finish(point, -ring, status, residual, F, fnorm, threshold, gate_norm=fxy)
    return contact, np.where(contact.status == NO_CONTACT, 0.0, theta)
