"""The probing schedule of §5.1, simulated on the rig: the chapter 5 replica's forward model.

Three passes ("fingers", §5.1) at heights ``z0 + k spacing``, six points per pass spread
``length`` along world y, two samples per point: 36 readings per surface.  For each point:

1. aim: the surface point hit by a ray along ``approach`` (default +x, straight ahead) at
   that (y, z), and the object's normal there;
2. place: IK puts the wheel centre at p + (L4 - delta) n, delta = force / stiffness
   (the commanded penetration of a penalty contact), wrist fixed (§5.1.3) or turned so the
   shaft points along -n;
3. touch: forward kinematics (``geometry.fk``) and the forward contact (``contact.wheel_touch``)
   give the actual contact, depth and normal; f_n = stiffness * depth;
4. feel: the wrench in the sensor frame (``contact.contact_wrench``, Coulomb friction opposing
   the tangential approach velocity when ``mu`` > 0), then sensor noise per sample;
5. gate: a sample is recorded only when the measured x-y force exceeds ``gate`` (§5.1).

Everything is returned as arrays, one row per sample, so the emulator and the tests share it.
"""

import numpy as np

from tactile_sim.rig.contact import contact_wrench, friction_direction, wheel_touch
from tactile_sim.rig.geometry import FREDDY, fk, ik, ik_fixed_wrist
from tactile_sim.rig.objects import ray_hit
from tactile_sim.rig.sensor import GATE_N, SIGMA_F, SIGMA_M, add_noise

__all__ = ["probe_schedule"]


def _targets(obj, passes, points, z0, spacing, length, approach, start_x):
    rows = []
    for k in range(passes):
        for j, y in enumerate(np.linspace(-0.5 * length, 0.5 * length, points)):
            p = ray_hit(obj, (start_x, y, z0 + k * spacing), approach, 0.5)
            rows.append((k, j, p))
    return rows


def probe_schedule(
    obj,
    rig=FREDDY,
    passes=3,
    points=6,
    samples=2,
    z0=0.10,
    spacing=0.02,
    length=0.06,
    force=1.3 * GATE_N,
    stiffness=2000.0,
    gate=GATE_N,
    mu=0.0,
    wrist="fixed",
    approach=(1.0, 0.0, 0.0),
    start_x=0.35,
    sigma_f=SIGMA_F,
    sigma_m=SIGMA_M,
    sigma_q=0.0,
    seed=None,
):
    """Simulate the §5.1 schedule on ``obj``; return a dict of per-sample arrays:

    ``q`` (n, 4) recorded joints (q1, q2, q3, z) [with encoder noise ``sigma_q``], ``force``,
    ``moment`` (n, 3) measured load in the sensor frame, ``recorded`` (n,) gate passed,
    ``point``, ``normal`` (n, 3) true world contact, ``theta`` true contact angle on the
    wheel, ``depth``, ``finger``, ``stop``, ``sample`` (n,).  ``seed=None`` and zero sigmas:
    noiseless, no random numbers drawn.  Unreachable or missed points have depth 0 and are
    never recorded (cf. the concave cylinder's missed point, §5.2.3).
    """
    noisy = np.any(np.asarray(sigma_f) > 0) or np.any(np.asarray(sigma_m) > 0) or sigma_q > 0
    rng = np.random.default_rng(seed) if noisy else None
    a = np.asarray(approach, float) / np.linalg.norm(approach)
    delta = force / stiffness
    targets = _targets(obj, passes, points, z0, spacing, length, a, start_x)
    q3_fixed = None
    if wrist == "fixed":
        mid = [p for k, j, p in targets if p is not None]
        if not mid:
            raise ValueError("no scheduled point reaches the object")
        centre = mid[len(mid) // 2] + (rig.L4 - delta) * obj.distance(mid[len(mid) // 2])[1]
        q3_fixed = ik(rig, centre, np.arctan2(a[1], a[0]))[2]
    out = {k: [] for k in ("q", "force", "moment", "point", "normal", "theta", "depth")}
    meta = {k: [] for k in ("finger", "stop", "sample")}
    for k, j, p in targets:
        touch = _place_and_touch(obj, rig, p, a, delta, wrist, q3_fixed)
        q, R, t, pw, nw, depth, th = touch
        fn = stiffness * max(depth, 0.0)
        ps, ns = R.T @ (pw - t), R.T @ nw
        slip = friction_direction(ns, R.T @ a) if mu else None
        F, M = contact_wrench(ps, ns, fn, mu, slip)
        for s in range(samples):
            Fm, Mm = add_noise(F, M, rng, sigma_f, sigma_m)
            qm = q + rng.normal(0.0, sigma_q, 4) * [1, 1, 1, 0] if sigma_q > 0 else q
            for key, val in zip(out, (qm, Fm, Mm, pw, nw, th, depth)):
                out[key].append(val)
            for key, val in zip(meta, (k, j, s)):
                meta[key].append(val)
    res = {key: np.array(v, dtype=float) for key, v in out.items()}
    res.update({key: np.array(v, dtype=int) for key, v in meta.items()})
    res["recorded"] = (np.hypot(res["force"][:, 0], res["force"][:, 1]) > gate) & (
        res["depth"] > 0.0
    )
    return res


def _place_and_touch(obj, rig, p, approach, delta, wrist, q3_fixed):
    """IK toward target p, then the actual contact from FK; a miss gives depth 0."""
    nothing = (np.zeros(4), np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3), 0.0, 0.0)
    if p is None:
        return nothing
    n = obj.distance(p)[1]
    # The rim is a horizontal circle: put it through p, its radial direction along the
    # horizontal part of n (so it is tangent to the surface there), then press in by delta.
    h = np.hypot(n[0], n[1])
    if h < 1e-9:
        return nothing  # a horizontal face cannot be felt with the x-y forces of the wheel
    centre = p + rig.L4 * np.array([n[0] / h, n[1] / h, 0.0]) - delta * n
    try:
        if wrist == "fixed":
            guess = np.arctan2(approach[1], approach[0])
            q = ik_fixed_wrist(rig, centre, q3_fixed, guess)
        else:
            q = ik(rig, centre, np.arctan2(-n[1], -n[0]))
    except ValueError:
        return nothing
    R, t = fk(rig, q)
    pw, nw, depth, th = wheel_touch(obj, R, t, rig.centre, rig.L4, rig.arc_limit)
    if depth <= 0.0:
        return (q, R, t, pw, nw, 0.0, th)
    return q, R, t, pw, nw, depth, th
