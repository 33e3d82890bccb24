"""``kind = "poses"``: the robot holds the unloaded fingers at a list of orientations.

What identifying the tool needs (``tactile payload identify``): the hand turns every sensor of
the board to each of ``orientations_deg`` in turn, holds it there for ``hold_s`` touching
nothing, and turns to the next over ``move_s`` along the shortest arc, with the (1 - cos)/2
profile of ``orientation.turn``.  The only load is the tool's weight (``[tool]``), which the
transducer adds at the orientation held; the contact wrench is zero throughout.

Orientation i is (roll, pitch, yaw) in degrees: R = Rz(yaw) Ry(pitch) Rx(roll), world from
sensor (``orientation.rpy_matrix``).  Hold i lasts from i (hold + move) to that plus hold, on
whole microseconds, so the pose log's windows and the load agree; the scene ends with the last
hold.

The robot's log (``write_pose_log``): the sensor-pose format of ``tactile.logs``,
one window per hold and sensor (``finger`` = the board's sensor index), each sensor at the
world's origin, turned; ``# sensor:`` states the sensor's noise and ``# end:`` the last hold's
end, where ``tactile record`` stops.

Keys (types, ranges and defaults in ``scene_schema.MOTION["poses"]``): ``orientations_deg``,
``hold_s``, ``move_s``.
"""

import numpy as np

from tactile.logs import write_log
from tactile_sim.emulator.orientation import Track, quaternion, rpy_matrix, turn


class PosesMotion:
    """Orientations held in turn, no contact; the pose log of the holds."""

    def __init__(self, orientations_deg, hold_s, move_s, sensors=1, noise=(0.0,) * 6):
        self.R = np.array([rpy_matrix(*rpy) for rpy in orientations_deg])
        self.sensors = sensors
        self.noise = np.broadcast_to(np.asarray(noise, float), (6,)).copy()
        hold, move = round(hold_s * 1e6), round(move_s * 1e6)
        starts = np.arange(len(self.R), dtype=np.int64) * (hold + move)
        self.windows_us = np.column_stack([starts, starts + hold])
        self.duration_s = float(self.windows_us[-1, 1]) * 1e-6
        w = self.windows_us * 1e-6
        t, q = [w[0, 0], w[0, 1]], [quaternion(self.R[0])] * 2
        for j in range(1, len(self.R)):
            tj, qj = turn(self.R[j - 1], self.R[j], w[j - 1, 1], w[j, 0])
            t += [*tj[1:], w[j, 1]]
            q += [*qj[1:], qj[-1]]
        self.attitude = Track(t, q)

    def wrench_at(self, t_s, sensor=0):
        """No contact: zero (6,) for a scalar time, (6, n) for an array."""
        return np.zeros((6,) + np.shape(t_s))

    def orientation_at(self, t_s, sensor=0):
        """R (3, 3), world from sensor: every sensor of the hand turns together."""
        return self.attitude.at(t_s)

    def poses(self):
        """Rows (t_start_us, t_end_us, finger, px, py, pz, qw, qx, qy, qz), one per hold and
        sensor: the sensor at the origin, held at the orientation."""
        quats = quaternion(self.R).tolist()
        return [
            (int(t0), int(t1), i, 0.0, 0.0, 0.0, *quats[j])
            for j, (t0, t1) in enumerate(self.windows_us)
            for i in range(self.sensors)
        ]

    def write_pose_log(self, path, at_us=0):
        """The robot's pose log (``tactile.logs``): the holds, the sensor's
        noise and the scene's end; ``at_us``: the board's clock at the scene's start."""
        end_us = at_us + int(self.windows_us[-1, 1])
        rows = [(t0 + at_us, t1 + at_us, *rest) for t0, t1, *rest in self.poses()]
        write_log(path, "pose", rows, sensor=self.noise, end_us=end_us)


def build(scene):
    """The poses motion of ``scene`` (keys checked by ``scene_schema``)."""
    m, s = scene.motion, scene.sensor
    noise = list(s["noise_force_N"]) + list(s["noise_torque_Nm"])
    return PosesMotion(m["orientations_deg"], m["hold_s"], m["move_s"],
                       scene.board["sensors"], noise)  # fmt: skip
