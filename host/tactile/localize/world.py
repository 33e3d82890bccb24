"""From the sensor frame to the world frame: the ch. 5 SCARA (eq. 62, fig. 38) or a pose log.

Frames (fig. 38).  World: z up, the SCARA's first joint axis through the origin.  The sensor
sits at the wrist, at the end of link 2, at height ``z`` set by the vertical axis (Freddy's
worm gear); its x axis runs along the probe shaft, at heading q1 + q2 + q3 in the world x-y
plane, its z axis is the world's.  So the sensor pose is

    R = Rot_z(q1 + q2 + q3),  t = (L1 cos q1 + L2 cos(q1+q2), L1 sin q1 + L2 sin(q1+q2), z),

and the wheel centre is (L3, 0, 0) in the sensor frame.  A point at angle theta on the wheel
(``probes.wheel_contact``) then lands at eq. 62's (x, y); ``eq62`` evaluates that formula
literally, for the tests to check ``to_world`` against.

A pose log (any robot) gives R, t per sample as 4x4 matrices or position + quaternion.

**Readings to world contacts**: localise on the probe, then map through the pose (§5.1.1).

``scara_contacts``: the ch. 5 rig (wheel probe on Freddy, eq. 62).  ``posed_contacts``: a
spherical fingertip on any robot with a pose log.  Both return a ``Contact`` whose point and
normal are in the WORLD frame (rows that are not contacts stay zero).

**The contacts CSV**: localised contacts written in the EP2 contacts-CSV contract (issue 3, §5.1.2).

A ``# units: m`` line, then a header row; ``x,y,z,nx,ny,nz`` (world frame; normals from the
object toward the finger, which is ``Contact.normal``), optional ``finger`` and ``patch``.
Only usable rows are written, so the file never holds a non-contact or a NaN.
"""

import numpy as np

from tactile import units
from tactile.localize.contact import NO_CONTACT
from tactile.localize.probes import rim_contact, sphere_contact, wheel_contact

__all__ = [
    "scara_pose",
    "eq62",
    "pose_from_matrix",
    "pose_from_quaternion",
    "to_world",
    "scara_contacts",
    "posed_contacts",
    "METHODS",
    "format_contacts",
]


def scara_pose(q1, q2, q3, z=0.0, L1=1.0, L2=1.0):
    """Sensor pose (R (..., 3, 3), t (..., 3)) of the ch. 5 SCARA for joint arrays (rad)."""
    q1, q2, q3, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (q1, q2, q3, z)))
    a12 = q1 + q2
    heading = a12 + q3
    c, s = np.cos(heading), np.sin(heading)
    zero, one = np.zeros_like(c), np.ones_like(c)
    R = np.stack(
        [np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)],
        axis=-2,
    )
    t = np.stack(
        [L1 * np.cos(q1) + L2 * np.cos(a12), L1 * np.sin(q1) + L2 * np.sin(a12), z], axis=-1
    )
    return R, t


def eq62(q1, q2, q3, theta, L1, L2, L3, L4):
    """World (x, y) of the contact at wheel angle ``theta``, literally eq. 62."""
    a1, a2, a3 = q1, q1 + q2, q1 + q2 + q3
    x = L1 * np.cos(a1) + L2 * np.cos(a2) + L3 * np.cos(a3) + L4 * np.cos(a3 + theta)
    y = L1 * np.sin(a1) + L2 * np.sin(a2) + L3 * np.sin(a3) + L4 * np.sin(a3 + theta)
    return x, y


def pose_from_matrix(T, atol=1e-6):
    """(R, t) from homogeneous 4x4 matrices (..., 4, 4); ValueError if R is not a rotation."""
    T = np.asarray(T, dtype=float)
    if T.shape[-2:] != (4, 4):
        raise ValueError(f"pose matrices must be (..., 4, 4), got {T.shape}")
    R, t = T[..., :3, :3], T[..., :3, 3]
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(initial=0.0)
    if not err <= atol or not np.all(np.linalg.det(R) > 0.0):
        raise ValueError(f"pose matrix is not a rigid motion (|R^T R - I| = {err:.3g})")
    return R, t


def pose_from_quaternion(position, quaternion, scalar_first=False):
    """(R, t) from positions (..., 3) and quaternions (..., 4), (x, y, z, w) by default
    (scipy's order) or (w, x, y, z) with ``scalar_first``; quaternions are normalised and a
    zero one is a ValueError."""
    q = np.asarray(quaternion, dtype=float)
    if scalar_first:
        q = np.concatenate([q[..., 1:], q[..., :1]], axis=-1)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if not np.all(norm > 0.0):
        raise ValueError("quaternion of zero length in the pose log")
    x, y, z, w = np.moveaxis(q / norm, -1, 0)
    R = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )
    return R, np.asarray(position, dtype=float)


def to_world(R, t, points, normals=None):
    """Map sensor-frame points (and normals) to the world: R p + t, R n."""
    pw = np.einsum("...ij,...j->...i", R, points) + t
    if normals is None:
        return pw
    return pw, np.einsum("...ij,...j->...i", R, normals)


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


def format_contacts(points, normals, finger=None, patch=None, unit=units.CONTACTS, mask=None):
    """CSV text for world ``points`` (metres) and ``normals`` (n, 3), under a ``# units:``
    line.  ``unit`` another length unit to write them in (SI unless asked); ``mask`` selects
    rows."""
    scale = units.LENGTH_M[units.SI_LENGTH] / units.length_factor(unit)
    P = np.asarray(points, dtype=float).reshape(-1, 3) * scale
    N = np.asarray(normals, dtype=float).reshape(-1, 3)
    keep = np.ones(len(P), bool) if mask is None else np.asarray(mask, bool).ravel()
    keep &= np.isfinite(P).all(axis=1) & np.isfinite(N).all(axis=1)
    keep &= np.linalg.norm(N, axis=1) > 0.0
    cols = ["x", "y", "z", "nx", "ny", "nz"]
    extra = []
    if finger is not None:
        cols.append("finger")
        extra.append(np.broadcast_to(np.asarray(finger), (len(P),)))
    if patch is not None:
        cols.append("patch")
        extra.append(np.broadcast_to(np.asarray(patch), (len(P),)))
    lines = [units.line(units.parse_length(unit)).rstrip("\n"), ",".join(cols)]
    for i in np.flatnonzero(keep):
        cells = [repr(float(v)) for v in (*P[i], *N[i])]
        cells += [str(e[i].item() if hasattr(e[i], "item") else e[i]) for e in extra]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"
