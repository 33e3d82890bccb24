"""The sensor's orientation in the world over time: rotations, quaternions and their tracks.

Every motion kind answers ``orientation_at(t_s, sensor)`` with R, the 3x3 rotation that takes
sensor-frame vectors to the world (world from sensor), the frame the robot's pose log is
written in.  A motion that turns keeps a ``Track``: unit quaternions (scalar first, as the
pose log writes them) at knot times, held before the first and after the last, linearly
interpolated and normalised in between (nlerp).  ``turn`` gives ``TURN_KNOTS`` + 1 knots of
the shortest arc from one orientation to another with the (1 - cos)/2 profile the roll uses;
between them the track is within 2 mrad of the exact turn for a half turn (the worst case,
``tests/test_emulator_gravity.py``), and exact wherever the hand holds still.

Conventions (docs/emulator.md): ``rpy_matrix(roll, pitch, yaw)`` = Rz(yaw) Ry(pitch) Rx(roll),
turned about world x, then y, then z.
"""

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

__all__ = ["TURN_KNOTS", "Track", "matrix", "quaternion", "rpy_matrix", "shortest_turn", "turn"]

TURN_KNOTS = 32  # knots per turn (33 with both ends)


def rpy_matrix(roll, pitch, yaw):
    """Rz(yaw) Ry(pitch) Rx(roll) for angles in degrees: world from sensor."""
    return Rotation.from_euler("xyz", [roll, pitch, yaw], degrees=True).as_matrix()


def quaternion(R):
    """Unit quaternions (..., 4), scalar first (qw, qx, qy, qz), of rotations R (..., 3, 3);
    the sign with qw >= 0."""
    q = np.roll(Rotation.from_matrix(np.asarray(R, float)).as_quat(), 1, axis=-1)
    return np.where(q[..., :1] < 0.0, -q, q)


def matrix(q):
    """Rotations (..., 3, 3) of quaternions (..., 4), scalar first (normalised here)."""
    q = np.asarray(q, float)
    return Rotation.from_quat(np.roll(q, -1, axis=-1)).as_matrix()


def _matrix(w, x, y, z):
    """The rotation (3, 3) of one quaternion, normalised here (plain arithmetic: the track is
    asked once per conversion instant)."""
    n = 2.0 / (w * w + x * x + y * y + z * z)
    return np.array([
        [1.0 - n * (y * y + z * z), n * (x * y - w * z), n * (x * z + w * y)],
        [n * (x * y + w * z), 1.0 - n * (x * x + z * z), n * (y * z - w * x)],
        [n * (x * z - w * y), n * (y * z + w * x), 1.0 - n * (x * x + y * y)],
    ])  # fmt: skip


def shortest_turn(a, b):
    """The rotation (3, 3) by the smallest angle that takes unit vector ``a`` onto ``b``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(a @ b)
    if s < 1e-15:
        if c > 0.0:
            return np.eye(3)
        # opposite: a half turn about any axis normal to a
        k = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return Rotation.from_rotvec(np.pi * k / np.linalg.norm(k)).as_matrix()
    return Rotation.from_rotvec(axis / s * np.arctan2(s, c)).as_matrix()


def turn(R0, R1, t0, t1, knots=TURN_KNOTS):
    """Knot times (knots + 1,) and quaternions (knots + 1, 4) of the shortest arc from R0 (at
    t0) to R1 (at t1), with the (1 - cos)/2 profile: the hand starts and stops smoothly."""
    tau = np.linspace(0.0, 1.0, knots + 1)
    arc = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([R0, R1])))
    q = np.roll(arc(0.5 * (1.0 - np.cos(np.pi * tau))).as_quat(), 1, axis=-1)
    return t0 + (t1 - t0) * tau, q


class Track:
    """Orientation over time from knots: ``at(t_s)`` is R (3, 3), world from sensor."""

    def __init__(self, t, q):
        self.t = np.asarray(t, float)
        q = np.array(q, float)
        for k in range(1, len(q)):  # each knot on the side of its neighbour (q and -q agree)
            if q[k] @ q[k - 1] < 0.0:
                q[k] = -q[k]
        self.q = q / np.linalg.norm(q, axis=1, keepdims=True)
        self.R = matrix(self.q)

    @classmethod
    def constant(cls, R):
        return cls([0.0], quaternion(R)[None])

    def at(self, t_s):
        """R (3, 3) at scene time ``t_s`` (s)."""
        t, n = self.t, len(self.t)
        j = int(np.searchsorted(t, t_s, side="right")) - 1
        if j < 0 or j >= n - 1:
            return self.R[0 if j < 0 else n - 1]
        f = (t_s - t[j]) / (t[j + 1] - t[j])
        if f <= 0.0:
            return self.R[j]
        return _matrix(*((1.0 - f) * self.q[j] + f * self.q[j + 1]).tolist())

    def quaternion_at(self, t_s):
        """(qw, qx, qy, qz) at ``t_s``, qw >= 0."""
        return quaternion(self.at(t_s))
