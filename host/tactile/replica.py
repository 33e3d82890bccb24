"""The chapter 5 experiment replicated (thesis §5.1-5.2, tables 5-7).

Functional pieces the CLI chains: contact frames and the robot's pose log
become world contacts (wheel probe, eqs. 60-62), the contacts become a
patch analysis with tangent- and position-weighted biquadratic fits on an
8x8 grid, and the results sit beside the thesis's tables.
"""

import numpy as np

from tactile_protocol import constants as C

# Thesis tables 5-7: (S, sd S, R, sd R, radius cm) for the tangent and position fits.
THESIS = {
    "plane": {"tangent": (0.4703, 0.21204, 0.004114, 0.0006562, None),
              "position": (0.3643, 0.24721, 0.003026, 0.0009828, None)},
    "convex": {"tangent": (0.4980, 0.009639, 0.080290, 0.024210, 8.8078),
               "position": (0.5014, 0.015773, 0.073446, 0.016892, 9.6304)},
    "concave": {"tangent": (-0.4878, 0.036813, 0.057014, 0.02732, 12.4155),
                "position": (-0.4483, 0.123840, 0.053336, 0.01799, 13.4831)},
}  # fmt: skip
TRUE_RADIUS_CM = {"plane": None, "convex": 6.6, "concave": 11.25}


def contact_samples(messages, per_contact=2):
    """The first ``per_contact`` CONTACT frames (BEGIN, then IN) of every contact.

    Returns (timestamps_us, wrench (n, 6) in N and N*m, contact ids).
    """
    taken = {}
    rows = []
    for m in messages:
        if m.type_name != "CONTACT" or m.phase == C.PHASE_END:
            continue
        if m.phase == C.PHASE_BEGIN:
            taken[m.contact_id] = 0
        k = taken.get(m.contact_id)
        if k is None or k >= per_contact:
            continue
        taken[m.contact_id] = k + 1
        rows.append((m.timestamp_us, m.contact_id, m.fx, m.fy, m.fz, m.tx, m.ty, m.tz))
    a = np.array(rows, dtype=float).reshape(-1, 8)
    return a[:, 0], a[:, 2:] * C.FORCE_LSB_N, a[:, 1].astype(int)


def joints_at(times_us, poses):
    """Joints (q1, q2, q3, z) and finger from the pose log rows covering each time.

    Rows are (t_start_us, t_end_us, finger, q1, q2, q3, z); a time outside every
    window gets NaN joints and finger -1, which the caller must drop.
    """
    poses = np.asarray(poses, dtype=float)
    joints = np.full((len(times_us), 4), np.nan)
    finger = np.full(len(times_us), -1)
    for i, t in enumerate(times_us):
        hit = np.nonzero((poses[:, 0] <= t) & (t <= poses[:, 1]))[0]
        if len(hit):
            joints[i] = poses[hit[0], 3:7]
            finger[i] = int(poses[hit[0], 2])
    return joints, finger


def world_contacts(times_us, wrench, poses, lengths, threshold):
    """World points (cm) and normals of the usable readings, with their finger."""
    from tactile.localize import scara_contacts

    joints, finger = joints_at(times_us, poses)
    posed = finger >= 0
    contact, _ = scara_contacts(
        wrench[posed, :3], wrench[posed, 3:], joints[posed], lengths, threshold=threshold
    )
    ok = np.asarray(contact.usable)
    return contact.point[ok] * 100.0, contact.normal[ok], finger[posed][ok]


def analyse(points_cm, normals, finger):
    """Tangent- and position-weighted biquadratic fits on an 8x8 grid (§5.2)."""
    from tactile.ep2 import analyze_patch

    out = {}
    for weighting in ("tangent", "position"):
        out[weighting] = analyze_patch(
            points_cm, normals, degree=2, weighting=weighting, grid=8, finger=finger
        )
    return out
