"""``kind = "commanded"``: an arm carrying the sensor over an EP2 object, moving only when told.

The object is the sweep's (``object``, ``radius_m``, ``rotation_deg`` of
``tactile_sim.ep2.objects``, its apex at the origin; ``tilt_deg`` turns it about the world
x axis).  The sensor carries a spherical fingertip of radius ``finger_radius_m`` whose centre
sits ``sensor_offset_m`` along the sensor's +x axis (its pole), as in the sweep.  The arm
starts at rest with the fingertip's centre at ``home_m`` and the pole pointing down (world
-z), and then does what ``tactile_sim.emulator.robot_server`` tells it:

- ``move(R, p, now)``: from where it is (after first backing out of a press) in a straight
  line at ``speed_mps`` to the sensor pose (R, p), turning along the shortest arc at
  ``TURN_RAD_S`` meanwhile; nothing touched, zero contact load;
- ``touch(start, d, f, travel, now)``: a move to the sensor origin ``start`` (orientation
  kept), then an approach of the fingertip's centre along d until the fingertip meets the
  object (``fingertip_contact.first_contact``), then a press of the penalty spring
  (``stiffness_N_m``) along d until the normal force is f, or the travel ends.  The press
  is held until the next command; its first ``hold_s`` is the hold the answer names.

The workspace (``workspace_min_m``, ``workspace_max_m``, world frame) bounds the fingertip's
centre: a pose outside it, or one with the fingertip inside the object, is refused
(``Unreachable``); an approach stops at its edge as at the end of its travel.

The load is the frictionless contact's (sensor frame, moment about the sensor origin):

    F = f n,    M = (c - o) x F

with n the surface's normal at the contact, c the fingertip's centre (the force's line goes
through it) and o the sensor origin, both where the press stopped.  It ramps linearly with
the press and back with the retreat; before and after it is zero.  Time is the scene's
(s): each command starts at ``now`` (the board's clock when it arrived) or when the one
before ended, whichever is later, and ends at ``end_s``.  Knots fall on whole microseconds,
so the hold windows (the pose log's rows) and the load agree.  ``wrench_at`` and
``orientation_at`` read the knots of the commands given so far (replaced whole per command:
the board's thread reads them while another thread commands), held after the last.
"""

import math

import numpy as np

from tactile.logs import write_log
from tactile.robot import RobotError
from tactile_sim.emulator.orientation import Track, matrix, quaternion, turn
from tactile_sim.ep2.fingertip_contact import first_contact, gap
from tactile_sim.ep2.objects import make

TURN_RAD_S = math.pi / 2  # the wrist turns at 90 deg/s
RAMP_MIN_S = 0.005  # a press or its release takes at least this long
CLEAR_M = 1e-9  # the fingertip may graze the object, not enter it

# The home orientation, world from sensor: the pole +x_S along world -z (as the sweep's).
DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


class Unreachable(RobotError):
    """A pose the arm cannot take: outside the workspace, or the fingertip in the object
    (exit 4, as a real arm's refusal; the line server answers it in one line)."""


def _us(t_s):
    return round(t_s * 1e6) * 1e-6


def _rot_x(deg):
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


class CommandedMotion:
    """The arm's pose and load over scene time; see the module docstring."""

    def __init__(self, cfg, obj, noise=(0.0,) * 6):
        self.cfg, self.obj = cfg, obj
        self.noise = np.broadcast_to(np.asarray(noise, float), (6,)).copy()
        self.radius, self.offset = cfg["finger_radius_m"], cfg["sensor_offset_m"]
        self.tilt = _rot_x(cfg["tilt_deg"])  # world from object
        self.box = np.array(cfg["workspace_min_m"]), np.array(cfg["workspace_max_m"])
        self.R = DOWN.copy()
        self.p = np.asarray(cfg["home_m"], float) - self.R[:, 0] * self.offset
        self.check(self.R, self.p, "home_m")
        self.end_s = 0.0  # when the last command's motion ends
        self.pressed = None  # (press travel (m), direction (3,)) while pressing
        self.holds = []  # pose-log rows (t0_us, t1_us, 0, px, py, pz, qw, qx, qy, qz)
        self._t, self._w = [0.0], [np.zeros(6)]
        self._qt, self._q = [0.0], [quaternion(self.R)]
        self._publish()

    # --- what the board reads ---------------------------------------------------------------
    def _publish(self):
        """Swap in the knots (one assignment each, so a reader sees old or new, never half)."""
        self._keys = (np.array(self._t), np.array(self._w))
        self._track = Track(self._qt, self._q)

    def wrench_at(self, t_s, sensor=0):
        """Load on the sensor at ``t_s`` (scalar -> (6,), array -> (6, n)); zero for a
        sensor the arm does not carry (only sensor 0 has the fingertip)."""
        if sensor != 0:
            return np.zeros((6,) + np.shape(t_s))
        t, w = self._keys
        return np.array([np.interp(t_s, t, w[:, c]) for c in range(6)])

    def orientation_at(self, t_s, sensor=0):
        """R (3, 3), world from sensor (every sensor on the one hand)."""
        return self._track.at(t_s)

    # --- geometry ---------------------------------------------------------------------------
    def centre(self, R, p):
        """The fingertip's centre (world) for the sensor pose (R, p)."""
        return np.asarray(p, float) + np.asarray(R, float)[:, 0] * self.offset

    def clearance(self, c):
        """The fingertip's gap to the object (m) with its centre at c (world)."""
        return gap(self.obj, self.tilt.T @ c)[0] - self.radius

    def check(self, R, p, what="pose"):
        """Refuse (``Unreachable``) a pose whose fingertip leaves the workspace or enters
        the object."""
        c = self.centre(R, p)
        lo, hi = self.box
        if np.any(c < lo - 1e-12) or np.any(c > hi + 1e-12):
            raise Unreachable(f"unreachable {what}: fingertip centre {_xyz(c)} m outside the "
                              f"workspace {_xyz(lo)}..{_xyz(hi)} m")  # fmt: skip
        gap_m = self.clearance(c)
        if gap_m < -CLEAR_M:
            raise Unreachable(f"unreachable {what}: the fingertip would be "
                              f"{-gap_m * 1e3:.3g} mm inside the object")  # fmt: skip

    def _in_box(self, c, d, travel):
        """The travel along d from c before the fingertip's centre leaves the box."""
        lo, hi = self.box
        limit = travel
        for k in range(3):
            if d[k] > 1e-15:
                limit = min(limit, (hi[k] - c[k]) / d[k])
            elif d[k] < -1e-15:
                limit = min(limit, (lo[k] - c[k]) / d[k])
        return max(0.0, limit)

    # --- commands ---------------------------------------------------------------------------
    def _begin(self, now_s):
        """The start of a command: now or the end of the last, whichever is later; a press
        still held is first backed out along its approach (the load ramps down)."""
        t = max(_us(now_s), self.end_s)
        if self.pressed is not None:
            depth, d = self.pressed
            self._key(t, self._w[-1])  # pressed until now
            t = self._key(t + max(depth / self.cfg["speed_mps"], RAMP_MIN_S), np.zeros(6))
            self.p = self.p - depth * d
            self.pressed = None
        return t

    def _key(self, t, w):
        """A load knot at ``t`` (whole µs); returns ``t``."""
        t = _us(t)
        if t > self._t[-1]:
            self._t.append(t)
            self._w.append(np.asarray(w, float))
        else:
            self._w[-1] = np.asarray(w, float)
        return t

    def _travel(self, t, R, p):
        """Move (no load) from the current pose to (R, p) from time t; the time it arrives."""
        dist = float(np.linalg.norm(np.asarray(p) - self.p))
        angle = _angle(self.R, R)
        dt = max(dist / self.cfg["speed_mps"], angle / TURN_RAD_S)
        end = _us(t + dt)
        if angle > 0.0:
            tq, q = turn(self.R, R, t, end)
            keep = tq > self._qt[-1]  # (the track holds its last knot until the turn)
            self._qt += tq[keep].tolist()
            self._q += list(q[keep])
        self._key(end, np.zeros(6))
        self.R, self.p = np.asarray(R, float), np.asarray(p, float)
        return end

    def pose(self):
        """(position (3,), quaternion (w, x, y, z)) of the sensor, world from sensor, where
        the last command leaves it."""
        return self.p.copy(), quaternion(self.R)

    def move(self, q, p, now_s):
        """Go to the sensor pose (unit quaternion q, world from sensor; position p); the time
        (s) the arm gets there."""
        R = matrix(q)
        self.check(R, p)
        t = self._travel(self._begin(now_s), R, p)
        self.end_s = t
        self._publish()
        return t

    def touch(self, start, d, force, travel, now_s):
        """Touch from the sensor origin ``start`` along unit d: (touched, travel (m), force
        (N), hold window (t0, t1) in s or None); the arm ends pressed (or at the travel's
        end), its hold window's end in ``end_s``."""
        start, d = np.asarray(start, float), np.asarray(d, float)
        self.check(self.R, start, "start")
        t = self._travel(self._begin(now_s), self.R, start)
        c0 = self.centre(self.R, start)
        reach = self._in_box(c0, d, travel)
        hit = first_contact(self.obj, self.tilt.T @ c0, self.tilt.T @ d, self.radius, reach)
        speed = self.cfg["speed_mps"]
        if hit is None:  # nothing within the travel (or the workspace)
            self.end_s = self._travel(t, self.R, start + reach * d)
            self._publish()
            return False, reach, 0.0, None
        n = self.tilt @ hit.normal
        t = self._travel(t, self.R, start + hit.s * d)
        cos = max(-float(d @ n), 1e-6)  # the approach's component into the surface
        depth = min(force / (self.cfg["stiffness_N_m"] * cos), reach - hit.s)
        f = self.cfg["stiffness_N_m"] * depth * cos
        self.p = start + (hit.s + depth) * d
        load = self._load(f, n)
        t0 = self._key(t + max(depth / speed, RAMP_MIN_S), load)
        t1 = self._key(t0 + self.cfg["hold_s"], load)
        self.pressed = (depth, d)
        self.end_s = t1
        self._publish()
        qw, qx, qy, qz = (float(v) for v in quaternion(self.R))
        self.holds.append((round(t0 * 1e6), round(t1 * 1e6), 0, *map(float, self.p),
                           qw, qx, qy, qz))  # fmt: skip
        return True, hit.s + depth, f, (t0, t1)

    def _load(self, f, n):
        """(6,) F, M in the sensor frame for normal force f along the world normal n."""
        F = f * n
        M = np.cross(self.centre(self.R, self.p) - self.p, F)
        return np.concatenate([self.R.T @ F, self.R.T @ M])

    # --- the pose log -----------------------------------------------------------------------
    def probe(self):
        """The fingertip in its sensor frame: (centre (3,), radius, pole axis (3,))."""
        return (self.offset, 0.0, 0.0), self.radius, (1, 0, 0)

    def poses(self):
        """Rows (t_start_us, t_end_us, finger, px, py, pz, qw, qx, qy, qz), one per hold."""
        return list(self.holds)

    def write_pose_log(self, path, at_us=0):
        """The robot's pose log of the holds so far (``tactile.logs``), with the
        fingertip and the sensor's noise; no end (the arm serves on)."""
        centre, radius, axis = self.probe()
        rows = [(t0 + at_us, t1 + at_us, *rest) for t0, t1, *rest in self.poses()]
        write_log(path, "pose", rows, probe=(radius, centre, axis), sensor=self.noise)


def _angle(R0, R1):
    """The angle (rad) of the turn from R0 to R1."""
    c = (np.trace(np.asarray(R0).T @ np.asarray(R1)) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))


def _xyz(v):
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"


def build(scene):
    """The commanded arm of ``scene`` (keys and their relations checked by ``scene_schema``)."""
    cfg = {k: v for k, v in scene.motion.items() if k != "kind"}
    noise = list(scene.sensor["noise_force_N"]) + list(scene.sensor["noise_torque_Nm"])
    obj = make(cfg["object"], radius=cfg["radius_m"], rotation_deg=cfg["rotation_deg"],
               centre=(0.0, 0.0))  # fmt: skip
    try:
        return CommandedMotion(cfg, obj, noise)
    except Unreachable as exc:
        raise scene.error("[motion] home_m", str(exc)) from None
