"""``kind = "sweep"``: EP2, several spherical fingertips swept over an object (ch. 4, fig. 24).

Each finger is a spherical fingertip of radius ``fingertip_radius_m`` on its own six-axis F/T
sensor (board sensor index = finger).  The fingers sit ``spacing_m`` apart along x and sweep
``length_m`` along y over a height-field object of ``tactile_sim.ep2.objects`` (its apex at
the origin); the contact stations are those of ``tactile_sim.ep2.sweep.sweep`` (one finger
track per finger, ``samples`` stations each), so the truth is the EP2 simulator's.

The sweep is stop-and-go (the thesis's discrete sampling, §5.1, on a tracking path): at each
station the fingertip rests on the surface with its centre at s + r n (rigid contact, force
controlled), then moves to the next station in ``settle_s``.  The load on finger k (ATI's
convention, sensor frame, moment about the sensor origin) is

    F = f_n (n + mu tau),   M = (s - o) x F,

with tau the unit tangent opposite the sweep direction (Coulomb friction of sliding along +y)
and o the sensor origin, which sits ``sensor_offset_m`` behind the fingertip centre along the
finger's pole; in the sensor frame the centre is (offset, 0, 0) and the pole +x, as in
``tactile_sim.rig.fingertip``.  f_n ramps up over ``ramp_s`` at the first station and down at
the last; between stations the load moves linearly from one station's to the next's; before
and after the sweep the finger is off (zero load), so the firmware's gate emits one contact
(BEGIN, IN..., END) per finger.  Noise belongs to the sensor model, so nothing here is random.

With ``wrist = "fixed"`` the hand keeps its orientation: the fingers point down (-z of the
object frame), finger k turned about its own pole by ``roll_deg[k]``.  With ``wrist =
"normal"`` the hand turns as a 6-axis arm does, so that at each station the pole points into
the surface along -n (the shortest turn from -z, then ``roll_deg[k]`` about the pole; the
contact is then at the pole): the turn between stations happens in ``settle_s``, along the
shortest arc (``orientation.turn``), and ``orientation_at`` follows it.  ``tilt_deg`` turns
object and hand about the world x axis, so the world is not the patch frame.

``poses()`` gives, per finger and station, the window in which the pose is held and the
sensor's pose in the world: the pose is exactly constant within each window (the moves
happen between windows, in ``settle_s``), so the pose log is exact, not an approximation.
Frames sampled during a move fall outside every window and the host drops them.  The log
also states the sensor's noise (``[sensor]`` of the scene, as a datasheet would), by which
the host drops the frames of the load ramps whose normals the noise swamps
(``tactile.localize.posed.normal_sd``).

Keys (SI units; types, ranges and defaults in ``scene_schema.MOTION["sweep"]``): ``object``
(``objects.KINDS``), ``radius_m``, ``rotation_deg``, ``tilt_deg``, ``fingers``, ``spacing_m``,
``length_m``, ``samples``, ``speed_mps``, ``settle_s``, ``fingertip_radius_m``,
``sensor_offset_m``, ``normal_force_N``, ``mu``, ``ramp_s``, ``rest_s``, ``roll_deg``, ``wrist``.
"""

import numpy as np

from tactile.logs import write_log
from tactile_sim.emulator.orientation import Track, quaternion, shortest_turn, turn
from tactile_sim.ep2.objects import make
from tactile_sim.ep2.sweep import sweep

# Sensor axes in the object frame for an untwisted finger: pole +x_S = -z, y_S = +y, z_S = +x.
_R0 = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


def _rot_x(deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def station_wrench(point, normal, R, origin, normal_force, mu, sweep_dir=(0.0, 1.0, 0.0)):
    """Load on the fingertip in its sensor frame for contacts (..., 3) (object frame).

    F = f_n (n + mu tau) with tau opposite the sweep direction's tangential part, and
    M = (s - o) x F about the sensor origin ``o``; both mapped by R^T (R: sensor -> object,
    (3, 3) for the whole track or (..., 3, 3) per station).  Returns (..., 6) = (F, M).
    """
    n = np.asarray(normal, float)
    d = np.asarray(sweep_dir, float)
    tan = d - np.einsum("...i,i->...", n, d)[..., None] * n
    tau = -tan / np.linalg.norm(tan, axis=-1, keepdims=True)
    F = normal_force * (n + mu * tau)
    M = np.cross(np.asarray(point, float) - origin, F)
    if np.ndim(R) > 2:  # R^T per station
        return np.concatenate([np.einsum("...ji,...j->...i", R, v) for v in (F, M)], axis=-1)
    return np.concatenate([F @ R, M @ R], axis=-1)


def wrist_normal(normals, roll_deg):
    """Sensor -> object (..., 3, 3) per station for ``wrist = "normal"``: the untwisted hand
    (pole -z) turned by the shortest arc that takes -z onto -n, so the pole points into the
    surface along its normal; then turned ``roll_deg`` about the pole."""
    twist = _R0 @ _rot_x(roll_deg)
    n = np.asarray(normals, float)
    turns = [shortest_turn((0.0, 0.0, 1.0), v) for v in n.reshape(-1, 3)]
    return (np.array(turns) @ twist).reshape(n.shape + (3,))


class SweepMotion:
    """Loads per sensor as piecewise-linear keyframes; the truth and the pose log per station."""

    def __init__(self, cfg, obj, noise=(0.0,) * 6):
        self.cfg = cfg
        self.obj = obj
        self.noise = np.broadcast_to(np.asarray(noise, float), (6,)).copy()  # (F, M) sigmas
        k, m = cfg["fingers"], cfg["samples"]
        r, off = cfg["fingertip_radius_m"], cfg["sensor_offset_m"]
        origin = (-0.5 * cfg["spacing_m"] * (k - 1), -0.5 * cfg["length_m"])
        # Noiseless, untilted: the object frame's stations (rows finger-major, sweep order).
        data = sweep(obj, k, cfg["spacing_m"], cfg["length_m"], m, 1, origin)
        s = data["points"].reshape(k, m, 3)
        n = data["normals"].reshape(k, m, 3)
        rolls = cfg["roll_deg"][:k]
        if cfg["wrist"] == "normal":  # sensor->object (k, m, 3, 3), per station
            self.R_obj = np.stack([wrist_normal(n[i], a) for i, a in enumerate(rolls)])
            pole = self.R_obj[..., 0]  # (k, m, 3): the pole axis in the object frame
        else:  # sensor->object (k, 3, 3), the whole track
            self.R_obj = np.stack([_R0 @ _rot_x(a) for a in rolls])
            pole = self.R_obj[:, None, :, 0]  # (k, 1, 3)
        centre = s + r * n
        sensor_origin = centre - off * pole
        self.wrench_stations = np.stack(
            [
                station_wrench(s[i], n[i], self.R_obj[i], sensor_origin[i],
                               cfg["normal_force_N"], cfg["mu"])
                for i in range(k)
            ]
        )  # fmt: skip
        # World = tilt about x of the object frame.
        self.tilt = _rot_x(cfg["tilt_deg"])
        self.points = s @ self.tilt.T  # true world contacts (k, m, 3)
        self.normals = n @ self.tilt.T
        self.sensor_R = self.tilt @ self.R_obj  # (k[, m], 3, 3) sensor -> world
        self.sensor_t = sensor_origin @ self.tilt.T  # (k, m, 3)
        self._timeline(m)
        self.hand = Track.constant(self.tilt @ _R0)  # a sensor without a finger
        self.attitude = [self._track(i) for i in range(k)]

    def _timeline(self, m):
        """Keyframes and pose windows on whole microseconds, so the log and the load agree."""
        cfg = self.cfg
        us = [round(cfg[k] * 1e6) for k in ("rest_s", "ramp_s", "settle_s")]
        rest, ramp, settle = us
        period = round(cfg["length_m"] / (m - 1) / cfg["speed_mps"] * 1e6)
        dwell = period - settle
        self.dwell_s = dwell * 1e-6
        # windows: station j holds its pose from start[j] to end[j] (ramps included at the ends)
        starts = rest + np.arange(m, dtype=np.int64) * period
        ends = starts + ramp + dwell
        starts[1:] += ramp
        ends[-1] += ramp
        self.windows_us = np.column_stack([starts, ends])
        # keyframes: 0 before, ramp up, hold, move (settle), ..., ramp down, 0 after
        t = [0, rest]
        w = [0, 0]
        for j in range(m):
            t += [starts[j] + (ramp if j == 0 else 0), ends[j] - (ramp if j == m - 1 else 0)]
            w += [j + 1, j + 1]
        t += [ends[-1], ends[-1] + rest]
        w += [0, 0]
        self.t = np.array(t, dtype=float) * 1e-6
        self.duration_s = float(self.t[-1])
        zero = np.zeros((self.wrench_stations.shape[0], 1, 6))
        table = np.concatenate([zero, self.wrench_stations], axis=1)  # index 0 = off
        self.keys = table[:, w, :]  # (k, len(t), 6)

    def _station_R(self, i):
        """(m, 3, 3): finger i's sensor -> world at each station."""
        R = self.sensor_R[i]
        return R if R.ndim == 3 else np.broadcast_to(R, (len(self.windows_us), 3, 3))

    def _track(self, i):
        """Finger i's orientation over time: held in each window, turned between them."""
        R = self._station_R(i)
        if self.sensor_R[i].ndim == 2:
            return Track.constant(R[0])
        w = self.windows_us * 1e-6
        t, q = [w[0, 0]], [quaternion(R[0])]
        for j in range(len(w)):
            if j:
                tj, qj = turn(R[j - 1], R[j], w[j - 1, 1], w[j, 0])
                t, q = t + list(tj[1:]), q + list(qj[1:])
            t.append(w[j, 1])
            q.append(q[-1])
        return Track(t, q)

    def orientation_at(self, t_s, sensor=0):
        """R (3, 3), world from sensor: finger ``sensor``'s, or the hand's for a sensor
        without a finger."""
        if sensor >= len(self.attitude):
            return self.hand.at(t_s)
        return self.attitude[sensor].at(t_s)

    def wrench_at(self, t_s, sensor=0):
        """Load on finger ``sensor`` at ``t_s`` (scalar -> (6,), array -> (6, n)); zero for
        a sensor without a finger."""
        if sensor >= self.keys.shape[0]:
            return np.zeros((6,) + np.shape(t_s))
        w = self.keys[sensor]
        return np.array([np.interp(t_s, self.t, w[:, c]) for c in range(6)])

    def true_contact(self, t_us, finger):
        """(points, normals, station) in the world at board times ``t_us`` (n,) inside the
        finger's windows; station -1 (and zero rows) outside them."""
        t = np.atleast_1d(np.asarray(t_us, dtype=np.int64))
        j = np.searchsorted(self.windows_us[:, 0], t, side="right") - 1
        ok = (j >= 0) & (t <= self.windows_us[np.clip(j, 0, None), 1])
        j = np.where(ok, j, -1)
        p = np.where(ok[:, None], self.points[finger, np.clip(j, 0, None)], 0.0)
        n = np.where(ok[:, None], self.normals[finger, np.clip(j, 0, None)], 0.0)
        return p, n, j

    def probe(self):
        """The fingertip in its sensor frame: (centre (3,), radius, pole axis (3,))."""
        return (self.cfg["sensor_offset_m"], 0.0, 0.0), self.cfg["fingertip_radius_m"], (1, 0, 0)

    def poses(self):
        """Rows (t_start_us, t_end_us, finger, px, py, pz, qw, qx, qy, qz) per finger and
        station: the sensor frame's world pose, held exactly during the window."""
        from scipy.spatial.transform import Rotation

        rows = []
        k, m = self.sensor_t.shape[:2]
        for i in range(k):
            if self.sensor_R[i].ndim == 2:  # (as always: scipy's sign, the same digits)
                qx, qy, qz, qw = map(float, Rotation.from_matrix(self.sensor_R[i]).as_quat())
                quats = [(qw, qx, qy, qz)] * m
            else:
                quats = quaternion(self.sensor_R[i]).tolist()
            for j in range(m):
                t0, t1 = (int(v) for v in self.windows_us[j])
                rows.append((t0, t1, i, *map(float, self.sensor_t[i, j]), *quats[j]))
        rows.sort(key=lambda r: (r[0], r[2]))
        return rows

    def write_pose_log(self, path, at_us=0):
        """The robot's pose log (``tactile.logs.read`` reads it), with the
        fingertip (``# probe:``), the F/T sensor's noise (``# sensor:``, its datasheet
        accuracy, §5.1.3), by which the host drops frames whose normal is noise, and the
        scene's end (``# end:``), where ``tactile record`` stops
        (``tactile.logs``); ``at_us``: the board's clock at the scene's start."""
        centre, radius, axis = self.probe()
        end_us = at_us + round(self.duration_s * 1e6)
        rows = [(t0 + at_us, t1 + at_us, *rest) for t0, t1, *rest in self.poses()]
        write_log(path, "pose", rows, probe=(radius, centre, axis), sensor=self.noise,
                  end_us=end_us)  # fmt: skip


def build(scene):
    """The sweep of ``scene`` (keys and their relations checked by ``scene_schema``)."""
    cfg = {k: v for k, v in scene.motion.items() if k != "kind"}
    noise = list(scene.sensor["noise_force_N"]) + list(scene.sensor["noise_torque_Nm"])
    try:
        obj = make(cfg["object"], radius=cfg["radius_m"], rotation_deg=cfg["rotation_deg"],
                   centre=(0.0, 0.0))  # fmt: skip
        motion = SweepMotion(cfg, obj, noise)
    except ValueError as exc:
        raise scene.error("[motion] object", str(exc)) from None
    return motion
