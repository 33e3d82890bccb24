"""``kind = "rig"``: the chapter 5 experiment, a SCARA probing an object point by point.

The probe schedule (``tactile_sim.rig``: §5.1's three passes x six points x
two samples, inverse kinematics, the contact wrench on the wheel) becomes a
load history: approach, press, hold, retract, rest, per scheduled point.
The sensor model adds the noise, so the schedule itself is noiseless.  The
robot's joint angles are not on the F/T wire: ``poses`` holds them per time
window, as the robot controller would log them (``write_pose_log``).

Keys: ``object`` (plane, convex, concave), ``passes``, ``points``,
``samples``, ``mu`` (Coulomb friction), ``hold_s``, ``speed_mps``, ``lead_in_s``
(the robot rests this long before the first approach: time for the host's TARE).
"""

import numpy as np

from tactile.logs import write_log
from tactile_sim.rig.geometry import FREDDY
from tactile_sim.rig.objects import ch5_object
from tactile_sim.rig.schedule import probe_schedule
from tactile_sim.rig.timeline import timeline, timeline_length

MAX_TIMELINE = 1_000_000  # load rows (one per board sample): ~17 min of probing at 1 kHz


class RigMotion:
    def __init__(self, schedule, line, lead_in_s=0.0, lengths=None):
        self.schedule = schedule
        self.lengths = lengths
        rest = [0.0] if lead_in_s > 0 else []
        self.t = np.concatenate([rest, line["t"] + lead_in_s])
        wrench = np.hstack([line["force"], line["moment"]])
        # column-major: np.interp takes each column as it is, where a strided one was
        # copied whole at each call (a ch5 scene: 23k rows, 6 copies per board sample)
        self.wrench = np.asfortranarray(np.vstack([np.zeros((len(rest), 6)), wrench]))
        self.onset = line["onset"] + lead_in_s
        self.release = line["release"] + lead_in_s
        self.touch = np.concatenate([np.full(len(rest), -1), line["touch"]])
        self.duration_s = float(self.t[-1]) if len(self.t) else 0.0
        # the touch under way at each row, else the last one (the first before any)
        last = np.maximum.accumulate(np.where(self.touch >= 0, self.touch, -1))
        first = self.touch[self.touch >= 0][:1]
        self._posed = np.where(last >= 0, last, first[0] if len(first) else -1)

    def wrench_at(self, t_s, sensor=0):
        t = np.asarray(t_s, float)
        return np.array([np.interp(t, self.t, self.wrench[:, k]) for k in range(6)])

    def orientation_at(self, t_s, sensor=0):
        """Rot_z(q1 + q2 + q3) of the touch under way (eq. 62; the last one between touches,
        the first before): the SCARA turns the sensor only about the world's vertical."""
        row = max(int(np.searchsorted(self.t, t_s, side="right")) - 1, 0)
        touch = self._posed[row] if len(self._posed) else -1
        a = float(np.sum(self.schedule["q"][touch][:3])) if touch >= 0 else 0.0
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def poses(self):
        """Rows (t_start_us, t_end_us, finger, q1, q2, q3, z): the joints during each touch."""
        rows = []
        for i in np.unique(self.touch[self.touch >= 0]):
            ts = self.t[self.touch == i]
            q = self.schedule["q"][i]
            finger = int(self.schedule["finger"][i])
            rows.append((int(ts[0] * 1e6), int(ts[-1] * 1e6), finger, *map(float, q)))
        return rows

    def write_pose_log(self, path, at_us=0):
        """The robot controller's log: joints per touch, the rig's lengths (m) and the scene's
        end (board us, where ``tactile record`` stops) in comments
        (``tactile.logs``); ``at_us``: the board's clock at the scene's start."""
        end_us = at_us + round(self.duration_s * 1e6)
        rows = [(t0 + at_us, t1 + at_us, *rest) for t0, t1, *rest in self.poses()]
        write_log(path, "scara", rows, rig=self.lengths, end_us=end_us)


def build(scene):
    """The rig motion of ``scene`` (keys checked by ``scene_schema``).

    The load is sampled at the board's rate, so the schedule's length in samples is
    checked before it is built: a refusal rather than minutes of work and gigabytes.
    """
    m = scene.motion
    schedule = probe_schedule(
        ch5_object(m["object"]),
        passes=m["passes"],
        points=m["points"],
        samples=m["samples"],
        mu=m["mu"],
        sigma_f=0.0,
        sigma_m=0.0,
        seed=None,
    )
    rate = float(scene.board["rate_hz"])
    pace = {"rate": rate, "hold": m["hold_s"], "speed": m["speed_mps"]}
    rows = timeline_length(schedule, **pace)
    if rows > MAX_TIMELINE:
        raise scene.error(
            "[motion]",
            f"the probing would take {rows} samples at {rate:g} Hz (at most {MAX_TIMELINE}):"
            " fewer passes, points or samples, a shorter hold_s or a faster speed_mps",
        )
    lengths = (FREDDY.L1, FREDDY.L2, FREDDY.L3, FREDDY.L4)
    return RigMotion(schedule, timeline(schedule, **pace), m["lead_in_s"], lengths)
