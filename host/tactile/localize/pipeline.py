"""Readings to world contacts: localise on the probe, then map through the pose (§5.1.1).

``scara_contacts``: the ch. 5 rig (wheel probe on Freddy, eq. 62).  ``posed_contacts``: a
spherical fingertip on any robot with a pose log.  Both return a ``Contact`` whose point and
normal are in the WORLD frame (rows that are not contacts stay zero).
"""

import numpy as np

from tactile.localize.contact import NO_CONTACT
from tactile.localize.kinematics import scara_pose, to_world
from tactile.localize.sphere import sphere_contact
from tactile.localize.wheel import rim_contact, wheel_contact

__all__ = ["scara_contacts", "posed_contacts", "METHODS"]

METHODS = ("force", "moment")


def _world(contact, R, t):
    p, n = to_world(R, t, contact.point, contact.normal)
    keep = (contact.status != NO_CONTACT)[..., None]  # flagged rows keep their best guess
    return contact._replace(point=np.where(keep, p, 0.0), normal=np.where(keep, n, 0.0))


def scara_contacts(
    force,
    moment,
    joints,
    lengths,
    threshold=0.0,
    method="force",
    half_thickness=np.inf,
    arc_limit=np.pi,
):
    """World contacts for readings (n, 3) taken at ``joints`` (n, 4) = (q1, q2, q3, z).

    ``lengths`` = (L1, L2, L3, L4) (fig. 38).  ``method="force"``: frictionless, eqs. 60-61
    (the thesis's); ``"moment"``: line of action on the rim, valid with friction.
    Returns (Contact in the world frame, theta on the wheel).
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose from {METHODS}")
    L1, L2, L3, L4 = lengths
    q = np.asarray(joints, dtype=float)
    centre = (L3, 0.0, 0.0)
    if method == "force":
        local, theta = wheel_contact(force, centre, L4, threshold, arc_limit)
    else:
        local, theta = rim_contact(
            force, moment, centre, L4, half_thickness, threshold, arc_limit=arc_limit
        )
    R, t = scara_pose(q[..., 0], q[..., 1], q[..., 2], q[..., 3], L1, L2)
    return _world(local, R, t), theta


def posed_contacts(force, moment, R, t, centre, radius, threshold=0.0, **kw):
    """World contacts on a spherical fingertip for readings with sensor poses (R, t)."""
    return _world(sphere_contact(force, moment, centre, radius, threshold, **kw), R, t)
