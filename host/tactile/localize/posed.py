"""CONTACT frames placed in the world through a robot's pose log (§5.1.1, §5.1.2).

The log itself (formats, clocks, reading) is ``tactile.logs.read``; ``sensor_poses`` turns
its windows into sensor poses (R, t).  ``posed_world_contacts`` takes the decoded CONTACT
frames (time, sensor, wrench), finds the window of each frame's finger that covers it,
localises the contact on the probe from force
and moment (``sphere_contact``, valid with friction) and maps it to the world (``to_world``).
A window's pose is taken as constant over the window: the log must say where the robot
held still (``tactile_sim.emulator.motion_sweep`` holds it exactly).  Frames outside every
window, below the gate, or that do not localise are dropped and counted.

The line of action is found from the moment (§5.1.1, with friction), so its error grows as
1/|F|: with the thesis's sensor (0.20/0.40 ozf, §5.1.3) a fingertip normal is good to ~6 deg
rms at 5 N but only to ~20 deg at 1.6 N, just above the 5 ozf gate, i.e. while the load
ramps up or down.
A generic log may say how noisy the F/T sensor is, ``# sensor: noise_force_N=sx,sy,sz
noise_torque_Nm=sx,sy,sz`` (1 sigma per axis, sensor frame); then each frame's normal error
is propagated to first order (``normal_sd``) and frames whose rms error exceeds
``max_normal_sd_deg`` are dropped and counted as ``imprecise``.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.errors import InputError
from tactile.localize.contact import NO_CONTACT
from tactile.localize.probes import sphere_contact
from tactile.localize.world import pose_from_quaternion, posed_contacts, scara_contacts, scara_pose

__all__ = [
    "PoseReport",
    "PosedContacts",
    "posed_world_contacts",
    "window_index",
    "sensor_poses",
    "normal_sd",
    "MAX_NORMAL_SD_DEG",
]

# Largest rms error (deg) of a kept frame's normal when the log gives the sensor's noise.  At
# the thesis's sensor noise a fingertip normal has ~6 deg at 5 N, so 10 deg keeps every frame
# at the working force and drops those below ~3 N (load ramps).  A kept normal then stays
# within 3.5 rms (35 deg; 1 frame in 2e5) of the truth, which with a sweep's own 34 deg of
# normal spread stays inside EP2's 70 deg consistency limit (tactile.ep2.geometry).
MAX_NORMAL_SD_DEG = 10.0


# Each localisation status (``contact.STATUS``, "imprecise") in a summary's words.
STATUS_WORDS = {
    "no_contact": "at or below the force gate",
    "near_miss": "near misses (kept)",
    "miss": "missing the fingertip",
    "off_probe": "off the probe's surface",
    "degenerate": "that cannot locate a point",
    "imprecise": "too noisy",
}


@dataclass
class PoseReport:
    """Where the frames went: ``frames`` in, ``outside`` (no window of their finger covers
    them), ``no_contact`` (|F| at or below the threshold), ``unusable`` (the line of action
    misses the probe or the point is off it), ``imprecise`` (localised, but the normal's
    propagated rms error exceeds the limit), ``usable``; ``status`` counts by name for the
    frames inside windows; ``kept`` the indices of the usable frames in the input."""

    frames: int
    outside: int
    no_contact: int
    unusable: int
    usable: int
    imprecise: int = 0
    status: dict = field(default_factory=dict)
    kept: np.ndarray = field(default_factory=lambda: np.zeros(0, int), repr=False)

    def __str__(self):
        """In words, for a summary line: where the readings that are not contacts went."""
        parts = [f"{self.outside:,} outside every pose window"] if self.outside else []
        for name, n in self.status.items():
            if name != "ok" and n:
                parts.append(f"{n:,} {STATUS_WORDS.get(name, name.replace('_', ' '))}")
        return ", ".join(parts) if parts else "every reading in a pose window localised"


@dataclass
class PosedContacts:
    """World contact points and object normals (n, 3) of the usable frames, their finger
    (n,), and the ``PoseReport``; ``normal_sd`` (n,) the normals' propagated rms error (rad)
    when the sensor noise is known, else None.  Unpacks as (points, normals, finger, report).
    """

    points: np.ndarray
    normals: np.ndarray
    finger: np.ndarray
    report: PoseReport
    normal_sd: np.ndarray | None = None

    def __iter__(self):
        return iter((self.points, self.normals, self.finger, self.report))


def normal_sd(force, moment, centre, radius, noise):
    """RMS angle (rad) of the fingertip normal's error from sensor noise, to first order.

    ``force``, ``moment`` (n, 3) as ``sphere_contact`` takes them (sensor frame, moment about
    the sensor origin), ``noise`` (6,) independent 1-sigma errors of (F, M) (§5.1.3).  The
    normal n(w) of the line of action's entry point (§5.1.1) is differentiated by central
    differences, and sqrt(sum_j sigma_j^2 |dn/dw_j|^2) returned (n,).  At a press on the
    pole with |F| = f this is sqrt(sM_y^2 + sM_z^2 + (c + r)^2 (sF_y^2 + sF_z^2)) / (f r).
    """
    F = np.asarray(force, dtype=float).reshape(-1, 3)
    M = np.asarray(moment, dtype=float).reshape(-1, 3)
    sigma = np.asarray(noise, dtype=float).ravel()
    W = np.concatenate([F, M], axis=1)
    var = np.zeros(len(W))
    for j in np.flatnonzero(sigma > 0):
        h = 1e-3 * sigma[j]  # well inside the linear range of a 1-sigma error
        up, down = W.copy(), W.copy()
        up[:, j] += h
        down[:, j] -= h
        n_up = sphere_contact(up[:, :3], up[:, 3:], centre, radius).normal
        n_down = sphere_contact(down[:, :3], down[:, 3:], centre, radius).normal
        dn = (n_up - n_down) / (2.0 * h)
        var += sigma[j] ** 2 * np.einsum("ij,ij->i", dn, dn)
    return np.sqrt(var)


def window_index(log, t_us, sensor, latency_us=0):
    """Index into ``log`` of the window covering each frame, -1 where none does.

    A frame stamped t covers [t - latency_us, t] (the sample may predate its stamp by up to
    the board's latency); the window must hold all of it.  Generic logs match ``finger`` to
    the sensor index; a SCARA log has one sensor and matches by time only.
    """
    t = np.asarray(t_us, dtype=np.int64).ravel()
    s = np.asarray(sensor, dtype=int).ravel()
    out = np.full(t.shape, -1)
    groups = [(None, np.arange(len(log)))] if log.kind == "scara" else None
    if groups is None:
        groups = [(f, np.flatnonzero(log.finger == f)) for f in np.unique(log.finger)]
    for f, rows in groups:
        rows = rows[np.argsort(log.t_start[rows], kind="stable")]
        mine = np.arange(len(t)) if f is None else np.flatnonzero(s == f)
        if not mine.size or not rows.size:
            continue
        early = t[mine] - int(latency_us)
        k = np.searchsorted(log.t_start[rows], early, side="right") - 1
        kk = np.clip(k, 0, None)
        hit = (k >= 0) & (t[mine] <= log.t_end[rows[kk]])
        out[mine[hit]] = rows[kk[hit]]
    return out


def sensor_poses(log, rows):
    """(R (k, 3, 3), t (k, 3) m): the sensor's pose in windows ``rows`` of ``log``: the
    logged position and quaternion, or a SCARA log's eq. 62 arm (its link lengths L1, L2;
    1 m each when the log has no ``# rig:`` line)."""
    rows = np.asarray(rows, dtype=int)
    if log.kind == "scara":
        L1, L2 = (log.lengths or (1.0, 1.0))[:2]
        q1, q2, q3, z = log.joints[rows].T
        return scara_pose(q1, q2, q3, z, L1, L2)
    return pose_from_quaternion(log.position[rows], log.quaternion[rows], scalar_first=True)


def posed_world_contacts(
    log,
    t_us,
    sensor,
    wrench,
    threshold,
    *,
    latency_us=0,
    centre=None,
    radius=None,
    axis=None,
    lengths=None,
    method="force",
    noise=None,
    max_normal_sd_deg=MAX_NORMAL_SD_DEG,
):
    """World contacts from CONTACT frames through a pose log.

    ``t_us`` (n,) frame times (whole microseconds in the log's clock), ``sensor`` (n,)
    board sensor index, ``wrench`` (n, 6) = (F, M) in N and N*m in that sensor's frame (the
    load on the probe, moment about the sensor origin).  Frames with |F| <= ``threshold``
    are not contacts.  Generic logs: the spherical fingertip of the log's ``# probe:`` line
    (or ``centre``, ``radius``, ``axis`` given here, which win), localised by
    ``sphere_contact`` (line of action of the force, exact with friction).  SCARA logs:
    ``scara_contacts`` with ``lengths`` = (L1, L2, L3, L4) (default: the log's ``# rig:``
    line) and ``method`` ("force": eqs. 60-61, the thesis's; "moment": with friction).

    With the sensor's ``noise`` (6,) (default: the log's ``# sensor:`` line) a generic log's
    frames whose normal has a propagated rms error (``normal_sd``) above ``max_normal_sd_deg``
    are dropped as ``imprecise``: the low-force frames of a load ramp, whose normals are
    otherwise noise (see the module docstring).  Without it every usable frame is kept.

    Returns ``PosedContacts(points, normals, finger, report, normal_sd)``, world frame, usable
    rows only, in input order; never NaN.
    """
    t = np.asarray(t_us).ravel()
    s = np.asarray(sensor).ravel()
    W = np.asarray(wrench, dtype=float).reshape(-1, 6)
    if not len(t) == len(s) == len(W):
        raise ValueError(f"t_us ({len(t)}), sensor ({len(s)}) and wrench ({len(W)}) differ")
    if not np.all(np.isfinite(W)):
        raise ValueError("wrench holds a non-finite value")
    idx = window_index(log, t, s, latency_us)
    inside = np.flatnonzero(idx >= 0)
    rows = idx[inside]
    F, M = W[inside, :3], W[inside, 3:]
    if log.kind == "scara":
        lengths = log.lengths if lengths is None else lengths
        if lengths is None:
            raise InputError(
                f"{log.path}: a SCARA pose log needs its link lengths:"
                " '# rig: scara L1=.. L2=.. L3=.. L4=..' (m)"
            )
        contact, _ = scara_contacts(F, M, log.joints[rows], lengths, threshold, method)
    else:
        probe = log.probe or {}
        c = probe.get("centre") if centre is None else centre
        r = probe.get("radius") if radius is None else radius
        ax = probe.get("axis") if axis is None else axis
        if c is None or r is None:
            raise InputError(
                f"{log.path}: no '# probe: sphere radius_m=R centre_m=cx,cy,cz' line;"
                " give the fingertip's centre and radius"
            )
        R, t_m = sensor_poses(log, rows)
        contact = posed_contacts(F, M, R, t_m, c, r, threshold, axis=ax)
    usable = np.asarray(contact.usable)
    names = np.array(contact.status_names(), dtype=object)
    unusable = int(np.sum(~usable & (contact.status != NO_CONTACT)))
    sd = None
    sigma = log.noise if noise is None else noise
    if log.kind == "pose" and sigma is not None:
        sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (6,))
        if not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
            raise ValueError(f"noise must be 6 finite sigmas >= 0, got {sigma!r}")
        sd = np.zeros(len(inside))
        sd[usable] = normal_sd(F[usable], M[usable], c, r, sigma)
        vague = usable & ~(sd <= np.radians(max_normal_sd_deg))
        names[vague] = "imprecise"
        usable = usable & ~vague
        sd = sd[usable]
    values, n = np.unique(names.astype(str), return_counts=True)
    counts = {str(v): int(k) for v, k in zip(values, n)}
    report = PoseReport(
        frames=len(t),
        outside=len(t) - len(inside),
        no_contact=counts.get("no_contact", 0),
        unusable=unusable,
        usable=int(usable.sum()),
        imprecise=counts.get("imprecise", 0),
        status=counts,
        kept=inside[usable],
    )
    finger = log.finger[rows[usable]]
    return PosedContacts(contact.point[usable], contact.normal[usable], finger, report, sd)
