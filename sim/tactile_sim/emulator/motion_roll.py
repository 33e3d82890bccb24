"""``kind = "roll"``: EP1 through a wrist F/T sensor, a spherical fingertip rolling on an object.

The robot presses the fingertip of eq. 20 (radius R1, on a six-axis wrist sensor) onto the
object, then performs the probes of §3.1-3.2: per direction, roll out by the commanded
rotation dtheta, hold, roll back to the start, hold (the "+" pattern of fig. 12 by default:
eight probes, each ending where the next starts).  Contact is kept throughout, so the
firmware streams CONTACT IN frames from the press to the release; the host reads the wrench
during the holds.  The path is Montana's rolling (``tactile_sim.ep1``: ``simulate_probes``
for the probes, ``rolling.rhs`` with dense output for the path in between) and the wrench is
``tactile_sim.rig.fingertip.fingertip_wrench`` (sensor frame, fingertip centre at
(offset, 0, 0), pole along +x).  Rotation follows a (1 - cos)/2 profile, so the finger
starts and stops smoothly; eqs. 24-28 are driftless, so the path depends only on the
rotation done, not its timing.

The robot's log (``probe_log``/``write_probe_log``): per probe, a time during the hold at its
start and at its end, and the commanded rotation (eq. 29's signs, contact frame at the
probe's start).  ``truth`` is K2~ at the start contact (``rolling.true_curvature``).

Keys (SI; types, ranges and defaults in ``scene_schema.MOTION["roll"]``): ``surface`` (a
``tactile_sim.ep1.surfaces.KINDS`` name) and ``surface_params`` (its parameters, in m),
``object_uv``, ``finger_uv``, ``psi`` (start contact), ``finger_radius_m``,
``sensor_offset_m``, ``normal_force_N``, ``mu`` (tangential load / normal load, a static
friction load inside the cone) along ``friction_dir_deg`` in the fingertip's tangent basis,
``dtheta_rad``, ``directions_deg``, and the timing ``rest_s``, ``press_s``, ``hold_s``,
``roll_s``, ``release_s``.
"""

import math

import numpy as np

from tactile.logs import ATTITUDE, write_log
from tactile_sim.emulator.orientation import Track, quaternion
from tactile_sim.ep1 import rolling
from tactile_sim.ep1.probes import measure, simulate_probes
from tactile_sim.ep1.rolling import CHART_MARGIN, axes, finger_pose, true_curvature
from tactile_sim.ep1.surfaces import fingertip, local, make
from tactile_sim.rig.fingertip import fingertip_wrench

HOLD_FRACTION = 0.8  # the central part of each hold that the log offers for reading
ROLL_KNOTS = 65  # path samples per roll (wrench linearly interpolated in between)


class RollMotion:
    """The load history of one EP1 run and the robot's log of it; see the module docstring."""

    def __init__(self, t, wrench, holds, commanded, probes, truth, geometry, attitude):
        self.t = t
        self.wrench = wrench  # (k, 6)
        self.attitude = attitude  # orientation.Track: the sensor in the world
        self.holds = holds  # (m + 1, 2) start, end of each hold (s)
        self.commanded = commanded  # (m, 2)
        self.probes = probes  # tactile_sim.ep1.probes.Probes (the simulator's true probes)
        self.truth = truth
        self.geometry = geometry
        self.duration_s = float(t[-1])

    def wrench_at(self, t_s, sensor=0):
        """Wrench (N, N*m) on the finger, sensor frame: (6,) for scalar t, (6, n) for arrays."""
        t = np.asarray(t_s, float)
        if sensor != 0:
            return np.zeros((6,) + t.shape)
        return np.array([np.interp(t, self.t, self.wrench[:, k]) for k in range(6)])

    def orientation_at(self, t_s, sensor=0):
        """R (3, 3), world from sensor: the rolling finger's attitude in a world whose +z is the
        object's outward normal at the start contact (the finger starts pointing down)."""
        return self.attitude.at(t_s)

    def hold_quaternions(self):
        """(qw, qx, qy, qz) of the sensor during each hold (m + 1, 4), world from sensor."""
        return np.array([self.attitude.quaternion_at(t) for t in self.holds.mean(axis=1)])

    def true_curvature(self):
        """K2~ at the start contact, in the finger's contact frame: dict kx, ky, K, k1, k2."""
        return self.truth

    def true_rows(self):
        """The simulator's true probes as (dtheta_x, dtheta_y, du, dv) rows (m, 4): net rotation
        from the normals (eqs. 34-35) and the exact change of the finger contact point."""

        return measure(self.probes, self.geometry["radius_m"])

    def probe_log(self):
        """Rows (probe, t_start_us, t_end_us, dtheta_x, dtheta_y, then ``ATTITUDE``): hold
        midpoints, the commanded rotation and the sensor's orientation in the world during
        the hold at the probe's start and at its end."""
        mid = np.rint(1e6 * self.holds.mean(axis=1)).astype(int)
        q = self.hold_quaternions().tolist()
        return [
            (i, int(mid[i]), int(mid[i + 1]), float(d[0]), float(d[1]), *q[i], *q[i + 1])
            for i, d in enumerate(self.commanded)
        ]

    def half_width_us(self):
        """Half the readable part of a hold, around the logged times (us)."""
        return int(0.5 * HOLD_FRACTION * 1e6 * float(np.min(np.diff(self.holds, axis=1))))

    def write_probe_log(self, path, at_us=0):
        """The robot's probe log (``tactile.logs``; ``tactile.logs.read`` reads it):
        the fingertip, the readable half width of a hold and the scene's end in comments;
        ``at_us``: the board's clock at the scene's start."""
        g = self.geometry
        probe = (g["radius_m"], g["centre_m"])
        end_us = at_us + round(self.duration_s * 1e6)
        rows = [(i, t0 + at_us, t1 + at_us, *rest) for i, t0, t1, *rest in self.probe_log()]
        write_log(path, "probe", rows, probe=probe, hold_us=self.half_width_us(),
                  end_us=end_us, more=ATTITUDE)  # fmt: skip


def _options(scene):
    """The scene's roll keys (checked by ``scene_schema``) as the build uses them."""
    o = dict(scene.motion)
    o["object_uv"] = np.array(o["object_uv"])
    o["finger_uv"] = np.array(o["finger_uv"])
    o["directions"] = np.radians(o.pop("directions_deg"))
    o["friction_dir"] = math.radians(o.pop("friction_dir_deg"))
    return o


def _paths(finger, obj, o):
    """The contact state (u1, v1, u2, v2, psi) along each roll out, at ROLL_KNOTS times of the
    (1 - cos)/2 profile: arrays (directions, ROLL_KNOTS, 5)."""
    from scipy.integrate import solve_ivp

    (u1, v1), (u2, v2) = o["finger_uv"], o["object_uv"]
    y0 = np.array([u1, v1, u2, v2, o["psi"], 0.0])
    progress = 0.5 * (1.0 - np.cos(np.pi * np.linspace(0.0, 1.0, ROLL_KNOTS)))
    out = []
    for phi in o["directions"]:
        omega = o["dtheta_rad"] * np.array([np.cos(phi), np.sin(phi), 0.0])
        sol = solve_ivp(
            rolling.rhs,
            (0.0, 1.0),
            y0,
            method=rolling.DEFAULT_METHOD,
            rtol=rolling.DEFAULT_RTOL,
            atol=rolling.DEFAULT_ATOL,
            args=(finger, obj, omega),
            dense_output=True,
        )
        out.append(sol.sol(progress)[:5].T)
    return np.array(out)


def build(scene):
    """The roll motion of ``scene`` (keys checked by ``scene_schema``).

    Geometry the schema cannot judge (a surface of 1e-247 m, a fingertip it cannot roll
    on) makes the rolling equations divide by zero or overflow: that is caught where it
    first happens, so it is one line naming the keys, neither a screen of numpy warnings
    nor seconds of integrating NaNs.
    """
    o = _options(scene)
    try:
        with np.errstate(divide="raise", over="raise", invalid="raise"):
            return _build(scene, o)
    except FloatingPointError as exc:
        raise scene.error(
            "[motion]",
            f"the rolling simulation breaks down ({exc}): check surface_params, "
            "finger_radius_m and the start contact",
        ) from None


def _starts_inside(scene, finger, obj, o):
    """The start contacts lie inside their charts: a roll that starts outside one never
    crosses its edge, so nothing would stop it integrating nonsense (for a minute)."""
    for key, surf in (("object_uv", obj), ("finger_uv", finger)):
        for k, name in enumerate("uv"):
            lo, hi = surf.chart[k]
            if not lo + CHART_MARGIN < o[key][k] < hi - CHART_MARGIN:
                raise scene.error(
                    f"[motion] {key}[{k}]",
                    f"must lie inside the {surf.name} chart ({lo:g} < {name} < {hi:g}), "
                    f"got {o[key][k]:g}",
                )


def _build(scene, o):
    try:
        obj = make(o["surface"], **o["surface_params"])
    except TypeError as exc:  # a parameter the surface does not take
        raise scene.error("[motion] surface_params", f"{o['surface']}: {exc}") from None
    R1 = o["finger_radius_m"]
    finger = fingertip(R1)
    _starts_inside(scene, finger, obj, o)
    probes = simulate_probes(
        finger, obj, o["finger_uv"], o["object_uv"], o["dtheta_rad"], o["directions"], o["psi"]
    )
    bad = [s for s in probes.status if s != "done"]
    if bad:
        raise scene.error("[motion] dtheta_rad", f"a roll stops early ({bad[0]}): roll less")
    paths = _paths(finger, obj, o)

    def load(uv, force):
        F, M = fingertip_wrench(
            uv[..., 0], uv[..., 1], R1, force, o["sensor_offset_m"], o["mu"], o["friction_dir"]
        )
        return np.concatenate([F, M], axis=-1)

    start = paths[0, 0]
    world = axes(local(obj, *start[2:4])).T  # world from object: the start normal up

    def attitude(states):
        return quaternion([world @ finger_pose(finger, obj, y)[0] for y in states])

    knots_t, knots_w = [0.0, o["rest_s"]], [np.zeros(6), np.zeros(6)]
    knots_q = [attitude([start])[0]] * 2
    t = o["rest_s"] + o["press_s"]
    knots_t.append(t)
    knots_w.append(load(start, o["normal_force_N"]))
    knots_q.append(knots_q[-1])
    holds = []
    tau = np.linspace(0.0, 1.0, ROLL_KNOTS)[1:]
    for path in paths:
        for leg in (path, path[::-1]):  # out, then back along the same path (eqs. 24-28)
            holds.append((t, t + o["hold_s"]))
            t += o["hold_s"]
            knots_t.append(t)
            knots_w.append(knots_w[-1])
            knots_q.append(knots_q[-1])
            knots_t.extend(t + o["roll_s"] * tau)
            knots_w.extend(load(leg[1:], o["normal_force_N"]))
            knots_q.extend(attitude(leg[1:]))
            t += o["roll_s"]
    holds.append((t, t + o["hold_s"]))
    t += o["hold_s"]
    knots_t += [t, t + o["release_s"], t + o["release_s"] + o["rest_s"]]
    knots_w += [knots_w[-1], np.zeros(6), np.zeros(6)]
    knots_q += [knots_q[-1]] * 3
    t_arr = np.array(knots_t)
    keep = np.append(np.diff(t_arr) > 0.0, True)  # drop a zero-length rest
    commanded = np.round(probes.axis, 15) * o["dtheta_rad"] + 0.0  # no -0.0 in the log
    geometry = {
        "radius_m": R1,
        "centre_m": (o["sensor_offset_m"], 0.0, 0.0),
        "normal_force_N": o["normal_force_N"],
    }
    truth = true_curvature(obj, o["object_uv"], o["psi"])
    track = Track(t_arr[keep], np.array(knots_q)[keep])
    return RollMotion(
        t_arr[keep], np.array(knots_w)[keep], np.array(holds), commanded, probes, truth,
        geometry, track,
    )  # fmt: skip
