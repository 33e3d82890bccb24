"""The §5.1 schedule as a stream in time, for the emulator: approach, press, hold, retract.

Each scheduled sample becomes one touch: the wheel moves along the approach from ``gap``
before the surface to the scheduled depth, holds, and backs off, at a constant speed; the load
is stiffness * depth (zero while depth <= 0) along the sample's noiseless wrench direction.
So the load is the schedule's true wrench scaled by depth/depth_final, and contact onset and
release fall exactly where depth crosses 0 (returned, for the emulator's contact-timing
tests).  Noise is left to the sensor model downstream.
"""

import numpy as np

__all__ = ["timeline", "timeline_length"]


def _spans(depth, gap, speed, hold, rest):
    """Each touch's duration (s): in, hold, out at ``speed``, then rest."""
    travel = gap + np.maximum(np.asarray(depth, float), 0.0)
    return 2 * travel / speed + hold + rest


def timeline_length(schedule, rate=1000.0, gap=0.002, speed=0.01, hold=0.05, rest=0.02):
    """Rows ``timeline`` would return for these arguments, without building them."""
    spans = _spans(schedule["depth"], gap, speed, hold, rest)
    return int(np.sum(np.ceil(spans * rate)))


def timeline(schedule, rate=1000.0, gap=0.002, speed=0.01, hold=0.05, rest=0.02):
    """Sampled load for every touch of ``probe_schedule(..., sigma_f=0, sigma_m=0)`` output.

    Returns a dict: ``t`` (n,) s, ``force``/``moment`` (n, 3) sensor frame, ``touch`` (n,)
    index of the scheduled sample (-1 between touches), ``onset``/``release`` (k,) times at
    which depth crosses zero for each touch that makes contact.
    """
    dt = 1.0 / rate
    t_all, F_all, M_all, idx_all, onset, release = [], [], [], [], [], []
    t0 = 0.0
    spans = _spans(schedule["depth"], gap, speed, hold, rest)
    for i, depth in enumerate(schedule["depth"]):
        travel = gap + max(depth, 0.0)
        span = spans[i]
        t = np.arange(int(np.ceil(span * rate))) * dt
        d = np.minimum(t, np.maximum(span - rest - t, 0.0))  # time spent moving in
        d = np.minimum(d * speed, travel) - gap  # depth profile
        d = np.where(t >= span - rest, -gap, d)
        scale = np.clip(d, 0.0, None) / depth if depth > 0.0 else np.zeros_like(d)
        F_all.append(scale[:, None] * schedule["force"][i])
        M_all.append(scale[:, None] * schedule["moment"][i])
        t_all.append(t0 + t)
        idx_all.append(np.where(t < span - rest, i, -1))
        if depth > 0.0:
            onset.append(t0 + gap / speed)
            release.append(t0 + span - rest - gap / speed)
        t0 += len(t) * dt
    return {
        "t": np.concatenate(t_all),
        "force": np.concatenate(F_all),
        "moment": np.concatenate(M_all),
        "touch": np.concatenate(idx_all),
        "onset": np.array(onset),
        "release": np.array(release),
    }
