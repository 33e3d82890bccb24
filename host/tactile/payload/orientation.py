"""The sensor's orientation at any reading's time, from a robot's log.

A robot log gives, per sensor, windows in which the sensor is held at a known pose
(``tactile.logs.read``: a generic log's quaternions, a SCARA log's joints).  A
reading inside a window has that window's orientation.  Between two windows of its sensor
the robot is moving and the log does not say how: the orientation is interpolated along
the shortest rotation from the end of one window to the start of the next, with a
(1 - cos)/2 profile in time (a move that starts and stops smoothly, as a robot's does and
the simulator's ``poses`` and ``sweep`` motions do).  Before the first window and after the
last, the nearest window's orientation holds.  ``at`` also says which readings are inside a
window (exact) and which are interpolated (as good as the robot's path is that arc).
"""

import numpy as np
from scipy.spatial.transform import Rotation

from tactile.errors import InputError
from tactile.localize.posed import sensor_poses
from tactile.logs.read import log_columns, read_pose_log, read_probe_log

__all__ = ["ANY", "Orientations", "read_log"]

ANY = -1  # the key of windows that hold for every sensor (a SCARA log has one sensor)


class Orientations:
    """Per sensor, windows [t_start, t_end] (us, the log's clock) and the sensor's
    orientation in each (``Rotation``, the sensor frame's axes in the world's)."""

    def __init__(self, windows, path=""):
        self.path = str(path)
        self.windows = {}
        for sensor, (t0, t1, rot) in windows.items():
            order = np.argsort(np.asarray(t0), kind="stable")
            self.windows[int(sensor)] = (
                np.asarray(t0, dtype=np.int64)[order],
                np.asarray(t1, dtype=np.int64)[order],
                rot[order],
            )

    @classmethod
    def of_log(cls, log):
        """From a pose log (``PoseLog``) or an EP1 probe log (``ProbeLog``) with orientations."""
        return cls.from_probe_log(log) if hasattr(log, "q_start") else cls.from_pose_log(log)

    @classmethod
    def from_pose_log(cls, log):
        """From a ``PoseLog``: a generic log's R per window and finger; a SCARA log's
        joints through eq. 62 (one sensor, every window)."""
        if log.kind == "scara":
            R, _ = sensor_poses(log, np.arange(len(log)))
            return cls({ANY: (log.t_start, log.t_end, Rotation.from_matrix(R))}, log.path)
        if log.quaternion is None:
            raise InputError(f"{log.path}: the log has no orientations (columns qw,qx,qy,qz)")
        out = {}
        for f in np.unique(log.finger):
            rows = np.flatnonzero(log.finger == f)
            R, _ = sensor_poses(log, rows)
            out[int(f)] = (log.t_start[rows], log.t_end[rows], Rotation.from_matrix(R))
        return cls(out, log.path)

    @classmethod
    def from_probe_log(cls, log):
        """From an EP1 ``ProbeLog`` with orientations: each probe's hold at its start and at
        its end (``half_width_us`` either side of the logged time), one sensor."""
        if log.q_start is None:
            raise InputError(
                f"{log.path}: the probe log has no orientations (columns qw,qx,qy,qz and"
                " qw_end,qx_end,qy_end,qz_end): the tool's weight cannot be removed"
            )
        half = round(log.half_width_us or 0)
        t = np.concatenate([log.t_start_us, log.t_end_us])
        q = np.concatenate([log.q_start, log.q_end])
        rot = Rotation.from_quat(np.roll(q, -1, axis=1))  # scipy: x, y, z, w
        return cls({ANY: (t - half, t + half, rot)}, log.path)

    def sensors(self):
        """The sensor indices the log has windows for (``ANY``: every sensor)."""
        return sorted(self.windows)

    def covers(self, sensor):
        """Whether the log says anything of ``sensor``'s orientation."""
        return int(sensor) in self.windows or ANY in self.windows

    def _of(self, sensor):
        got = self.windows.get(int(sensor), self.windows.get(ANY))
        if got is None:
            raise InputError(
                f"{self.path}: no window of sensor {int(sensor)} (the log has"
                f" {', '.join(str(s) for s in self.sensors())})"
            )
        return got

    def at(self, sensor, t_us):
        """(R (n, 3, 3), held (n,) bool) of ``sensor`` at times ``t_us`` (n,): a window's
        orientation inside it, interpolated between windows (module docstring)."""
        t0, t1, rot = self._of(sensor)
        t = np.asarray(t_us, dtype=np.int64).ravel()
        k = np.searchsorted(t0, t, side="right") - 1
        inside = (k >= 0) & (t <= t1[np.clip(k, 0, None)])
        k = np.clip(k, 0, len(t0) - 1)
        out = rot[k]
        moving = np.flatnonzero(~inside & (t > t1[k]) & (k + 1 < len(t0)))
        if moving.size:
            a, b = k[moving], k[moving] + 1
            span = np.maximum(t0[b] - t1[a], 1).astype(float)
            frac = (1.0 - np.cos(np.pi * np.clip((t[moving] - t1[a]) / span, 0.0, 1.0))) / 2
            step = (rot[a].inv() * rot[b]).as_rotvec()
            between = rot[a] * Rotation.from_rotvec(frac[:, None] * step)
            R = out.as_matrix()
            R[moving] = between.as_matrix()
            return R, inside
        return out.as_matrix().reshape(-1, 3, 3), inside

    def held_windows(self, sensor):
        """(t_start (k,), t_end (k,), R (k, 3, 3)) of ``sensor``'s windows, in time order."""
        t0, t1, rot = self._of(sensor)
        return t0, t1, rot.as_matrix().reshape(-1, 3, 3)


def read_log(path):
    """(the log, its ``Orientations``) of a robot log at ``path``: an EP1 probe log (with
    orientation columns) or a pose log; InputError when it gives no orientation."""
    log = read_probe_log(path) if "dtheta_x" in log_columns(path) else read_pose_log(path)
    return log, Orientations.of_log(log)
