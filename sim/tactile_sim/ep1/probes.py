"""EP1 probing motions and the measurement model (§3.1-3.3).

A probe rolls the finger about the axis ``(cos phi, sin phi, 0)`` of its instantaneous contact
frame through ``dtheta`` and then rolls back (§3.1 steps 1-4).  The "+" pattern (fig. 12) is
phi = 0, pi, pi/2, 3 pi/2 (+x, -x, +y, -y), each out and back: eight probes.

What a probe *measures* (all in the contact frame at the probe's start):

- net rotation from the finger normal at the start point before and after (eqs. 34-35):
  angle atan2(|a x b|, a.b) about the unit axis a x b, which is the thesis's
  sign-from-(z1 x z2).x1 rule extended to any direction;
- the change (du, dv) of the contact point in the fingertip parameters of eq. 20.

Noise (§3.3.1, §3.3.3), applied by ``measure`` to arrays of true probes:
angle noise N(0, sigma_theta) along the commanded axis; the contact sensor is
'exact', 'array' (positions on a grid of pitch r in (R1 u, R1 v), rounded to the nearest
element), 'gauss' (error N(0, r) along the motion) or 'bias' (+r along the motion: the
literal fig. 20 model, "added to the final positions ... in the direction of the rolling").
"""

from typing import NamedTuple

import numpy as np

from tactile_sim.ep1.rolling import finger_pose, roll, sphere_on_sphere
from tactile_sim.ep1.surfaces import local

__all__ = [
    "PLUS",
    "Probes",
    "net_rotation",
    "simulate_probes",
    "sphere_plus_probes",
    "measure",
    "tile",
    "SENSORS",
]

PLUS = np.array([0.0, np.pi, 0.5 * np.pi, 1.5 * np.pi])  # +x, -x, +y, -y
SENSORS = ("exact", "array", "gauss", "bias")


class Probes(NamedTuple):
    """True probe data, arrays with a leading probe axis (shape (..., n))."""

    dtheta: np.ndarray  # (..., n, 2) net rotation (x, y) in the start contact frame
    p_start: np.ndarray  # (..., n, 2) fingertip (u, v) at the probe's start
    p_end: np.ndarray  # (..., n, 2)
    axis: np.ndarray  # (..., n, 2) commanded unit rotation axis
    ds: np.ndarray  # (..., n) arc length on the finger (eq. 28)
    status: list  # per probe: 'done' or why the roll stopped


def net_rotation(finger, obj, y_start, y_end):
    """Finger rotation between two states, from normals (eqs. 34-35), in the start frame."""
    R1, _ = finger_pose(finger, obj, y_start)
    R2, _ = finger_pose(finger, obj, y_end)
    g = local(finger, y_start[0], y_start[1])
    a, b = R1 @ g.z, R2 @ g.z
    c = np.cross(a, b)
    sin = np.sqrt(c @ c)
    angle = np.arctan2(sin, a @ b)
    if sin == 0.0:
        return np.zeros(2)
    axis = c / sin
    return angle * np.array([axis @ (R1 @ g.x), axis @ (R1 @ g.y)])


def simulate_probes(finger, obj, p1, p2, dtheta, phis=PLUS, psi=0.0, back=True, **roll_kw):
    """Roll out (and back) along each direction ``phi``; return the true ``Probes``.

    ``roll_kw`` goes to ``rolling.roll`` (method, rtol, atol).  A roll that leaves a chart or
    loses contact keeps its partial result and its status.
    """
    rows = []
    y0 = np.array([p1[0], p1[1], p2[0], p2[1], psi, 0.0], dtype=float)
    for phi in np.atleast_1d(phis):
        axis = np.array([np.cos(phi), np.sin(phi)])
        out = roll(finger, obj, p1, p2, psi, dtheta * np.append(axis, 0.0), **roll_kw)
        y1 = out.y
        rows.append((net_rotation(finger, obj, y0, y1), y0[:2], y1[:2], axis, y1[5], out.status))
        if back:
            # Eqs. 24-28 are linear in omega, so reversing omega for the same time retraces the
            # path exactly: the return probe ends at the start.
            rows.append(
                (net_rotation(finger, obj, y1, y0), y1[:2], y0[:2], -axis, y1[5], out.status)
            )
    dth, ps, pe, ax, ds, st = zip(*rows, strict=True)
    return Probes(np.array(dth), np.array(ps), np.array(pe), np.array(ax), np.array(ds), list(st))


def sphere_plus_probes(R1, R2, dtheta, u0=0.0, v0=0.0):
    """Fast path: the eight '+' probes on a sphere from the closed form of eq. 38.

    The contact displacement is exact for any start (eq. 38 integrated).  The measured rotation
    equals the commanded one when each roll follows a great circle, i.e. for the '+' pattern
    from u0 = 0 (the studies' case; checked against the ODE in the tests).  ``R2`` and
    ``dtheta`` broadcast; the result has shape (broadcast..., 8, ...).
    """
    R2, dtheta = np.broadcast_arrays(np.asarray(R2, float), np.asarray(dtheta, float))
    axes = np.stack([np.cos(PLUS), np.sin(PLUS)], axis=-1).round(15)
    wx = dtheta[..., None] * axes[:, 0]
    wy = dtheta[..., None] * axes[:, 1]
    u, v, s = sphere_on_sphere(R1, R2[..., None], u0, v0, wx, wy)
    start = np.broadcast_to(np.array([u0, v0]), u.shape + (2,))
    end = np.stack([u, v], axis=-1)
    dth = np.stack([wx, wy], axis=-1)
    # interleave each roll out with its return: (out_i, back_i)
    shape = u.shape[:-1] + (8,)
    ps = np.empty(shape + (2,))
    pe = np.empty(shape + (2,))
    th = np.empty(shape + (2,))
    ax = np.empty(shape + (2,))
    ds = np.empty(shape)
    ps[..., 0::2, :], pe[..., 0::2, :], th[..., 0::2, :] = start, end, dth
    ps[..., 1::2, :], pe[..., 1::2, :], th[..., 1::2, :] = end, start, -dth
    ax[..., 0::2, :], ax[..., 1::2, :] = axes, -axes
    ds[..., 0::2], ds[..., 1::2] = s, s
    return Probes(th, ps, pe, ax, ds, ["done"] * 8)


def tile(probes, trials):
    """Probes repeated along a new leading Monte-Carlo axis of length ``trials`` (views)."""

    def rep(a):
        return np.broadcast_to(a, (trials,) + np.shape(a))

    return probes._replace(
        dtheta=rep(probes.dtheta),
        p_start=rep(probes.p_start),
        p_end=rep(probes.p_end),
        axis=rep(probes.axis),
        ds=rep(probes.ds),
    )


def measure(probes, R1, sigma_theta=0.0, resolution=0.0, sensor="exact", rng=None, offset=0.0):
    """Measured (dtheta_x, dtheta_y, du, dv) arrays of shape (..., n, 4) for true ``probes``.

    ``resolution`` r is in arc length on the fingertip; ``offset`` shifts the array grid
    (in units of r) relative to the start point, scalar or broadcastable to (..., n, 2).
    """
    if sensor not in SENSORS:
        raise ValueError(f"unknown sensor {sensor!r}; choose from {', '.join(SENSORS)}")
    rng = np.random.default_rng() if rng is None else rng
    dth = probes.dtheta
    if sigma_theta > 0.0:
        dth = dth + rng.normal(0.0, sigma_theta, dth.shape[:-1])[..., None] * probes.axis
    motion = np.stack([-probes.axis[..., 1], probes.axis[..., 0]], axis=-1)  # (x, y) = (u, v)
    dp = probes.p_end - probes.p_start
    if resolution > 0.0 and sensor != "exact":
        r = resolution / R1  # one step in parameter units
        if sensor == "array":
            grid = lambda p: (np.round(p / r - offset) + offset) * r  # noqa: E731
            dp = grid(probes.p_end) - grid(probes.p_start)
        elif sensor == "gauss":
            dp = dp + rng.normal(0.0, r, dp.shape[:-1])[..., None] * motion
        else:  # bias
            dp = dp + r * motion
    return np.concatenate([dth, dp], axis=-1)
