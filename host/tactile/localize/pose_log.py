"""A robot's pose log, and CONTACT frames placed in the world through it (§5.1.1, §5.1.2).

The F/T wire carries no pose: the robot controller logs, per finger, time windows in which
the pose of that finger's sensor is held.  Two formats (CSV, ``#`` comment lines allowed; the
columns, comment lines and time columns are ``tactile.robot_log``'s, which writes them too):

- generic (any robot): ``t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz``: the sensor
  frame's pose in the world during the window (position in metres, unit quaternion scalar
  first); ``finger`` is the board's sensor index.  A comment line
  ``# probe: sphere radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az]`` gives the spherical
  fingertip in the sensor frame (centre, radius and, optionally, the pole of a hemisphere);
- SCARA (the ch. 5 rig, ``motion_rig.write_pose_log``): ``t_start_us,t_end_us,finger,q1,q2,
  q3,z``: joint angles (rad) and height (m) of eq. 62; one sensor (index 0) and ``finger``
  is the pass.  Placing its frames needs the link lengths, from a comment line
  ``# rig: scara L1=.. L2=.. L3=.. L4=..`` (m) or given to ``posed_world_contacts``.

Times: ``t_start_us,t_end_us`` are the board's clock; a log stamped by the robot's own clock
names it instead with ``t_start_utc_s,t_end_utc_s`` (UTC) or ``t_start_mono_s,t_end_mono_s``
(the recording host's monotonic clock), joined through the recording's time base
(``tactile.log_clock``).  ``# end: t_us=N`` (or ``t_utc_s=``, ``t_mono_s=``) says when the
robot is done; ``tactile record`` stops there.

``posed_world_contacts`` takes the decoded CONTACT frames (time, sensor, wrench), finds the
window of each frame's finger that covers it, localises the contact on the probe from force
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

from tactile import robot_log, units
from tactile.errors import InputError, where
from tactile.localize.contact import NO_CONTACT
from tactile.tabular import show

__all__ = [
    "PoseLog",
    "PosedContacts",
    "read_pose_log",
    "posed_world_contacts",
    "normal_sd",
    "MAX_NORMAL_SD_DEG",
]

GENERIC = robot_log.COLUMNS["pose"]  # the format's columns (tactile.robot_log)
SCARA = robot_log.COLUMNS["scara"]
MAX_FINGER = 2**31 - 1  # a sensor index (generic log) or a pass number (SCARA log)
LIMIT = 1e6  # |value| of a position (m), angle (rad), length (m) or sensor noise (N, N*m)
MIN_RADIUS_M = 1e-6  # a fingertip's radius

# Largest rms error (deg) of a kept frame's normal when the log gives the sensor's noise.  At
# the thesis's sensor noise a fingertip normal has ~6 deg at 5 N, so 10 deg keeps every frame
# at the working force and drops those below ~3 N (load ramps).  A kept normal then stays
# within 3.5 rms (35 deg; 1 frame in 2e5) of the truth, which with a sweep's own 34 deg of
# normal spread stays inside EP2's 70 deg consistency limit (tactile.ep2.patch_frame).
MAX_NORMAL_SD_DEG = 10.0


@dataclass
class PoseLog:
    """Windows (n,) with their finger and pose; ``kind`` "pose" (R, t set) or "scara"
    (``joints`` (n, 4) set); ``probe`` = {"radius", "centre", "axis"} or None; ``lengths``
    (L1, L2, L3, L4) of a SCARA log's ``# rig:`` line or None; ``noise`` (6,) the F/T
    sensor's 1-sigma noise (N, N*m) of a ``# sensor:`` line or None."""

    path: str
    kind: str
    t_start: np.ndarray
    t_end: np.ndarray
    finger: np.ndarray
    lines: list
    R: np.ndarray | None = None
    t: np.ndarray | None = None
    joints: np.ndarray | None = None
    probe: dict | None = None
    lengths: tuple | None = None
    noise: np.ndarray | None = None
    clock: str = "board"  # of t_start/t_end (us): "board", "utc" or "monotonic"
    end_us: int | None = None  # the '# end:' line's time, in that clock

    def __len__(self):
        return len(self.t_start)


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


# --- reading -------------------------------------------------------------------------------


def read_pose_log(path):
    """Read a pose log (generic or SCARA, see the module docstring) into a ``PoseLog``.

    Every error is one ``InputError`` line naming file:line and the column.
    """
    from tactile.log_clock import CLOCKS, clock_of, parse_end, read_times
    from tactile.tabular import read_csv

    units.check_stated(path, units.LOG_WORDS, units.LOG_WHAT)
    tags, header_line, header = _scan(path)
    names = {h.strip() for h in header}
    shown = ",".join(show(h.strip(), 20, False) for h in header[:20])
    clock = clock_of(path, header_line, names)
    if clock is not None and set(GENERIC[2:]) <= names:
        kind, rest = "pose", GENERIC[2:]
    elif clock is not None and set(SCARA[2:]) <= names:
        kind, rest = "scara", SCARA[2:]
    else:
        raise InputError(
            f"{where(path, header_line)}: expected columns {','.join(GENERIC)} (or the SCARA"
            f" log's {','.join(SCARA)}; or t_start_utc_s,t_end_utc_s or t_start_mono_s,"
            f"t_end_mono_s for the times); header has: {shown}"
        )
    table = read_csv(path, CLOCKS[clock][:2] + rest)
    lines = list(table.lines)
    t_start, t_end = read_times(table, clock)
    finger = table.whole("finger", 0, MAX_FINGER)
    log = PoseLog(str(path), kind, t_start, t_end, finger, lines, clock=clock)
    if "end" in tags:
        log.end_us = parse_end(path, *tags["end"], clock)
    _check_overlap(log)
    if kind == "pose":
        from tactile.localize.kinematics import pose_from_quaternion

        q = table.within(("qw", "qx", "qy", "qz"), LIMIT)
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > 1e-3)
        if bad.size:
            raise InputError(
                f"{where(path, lines[bad[0]], 'qw')}: quaternion (qw,qx,qy,qz) is not unit"
                f" length (|q| = {norm[bad[0]]:.6g})"
            )
        p = table.within(("px", "py", "pz"), LIMIT)
        log.R, log.t = pose_from_quaternion(p, q, scalar_first=True)
    else:
        log.joints = table.within(("q1", "q2", "q3", "z"), LIMIT)
        if "rig" in tags:
            log.lengths = _parse_rig(path, *tags["rig"])
    if "probe" in tags:
        log.probe = _parse_probe(path, *tags["probe"])
    if "sensor" in tags:
        log.noise = _parse_sensor(path, *tags["sensor"])
    return log


def log_columns(path):
    """The header row's column names of a robot log (after its ``#`` lines), stripped."""
    return [h.strip() for h in _scan(path)[2]]


def _scan(path):
    """{tag: (line number, text)} of ``# tag: text`` comments (probe, rig, sensor, end) before the
    header, the header's line number and the header row."""
    from tactile.tabular import preamble

    comments, header_line, header = preamble(path)
    tags = {}
    for no, s in comments:
        tag, colon, body = s[1:].partition(":")
        if colon and tag.strip() in robot_log.TAGS:
            tags[tag.strip()] = (no, body.strip())
    return tags, header_line, header


def _parse_probe(path, line, text):
    words = text.split()
    if not words or words[0] != "sphere":
        raise InputError(f"{where(path, line)}: probe: only 'sphere' is known, got {show(text)}")
    out = {"axis": None}
    need = {"radius_m": 1, "centre_m": 3, "axis": 3}
    for word in words[1:]:
        key, eq, value = word.partition("=")
        if key not in need or not eq:
            raise InputError(
                f"{where(path, line)}: probe: unknown field {show(word)}"
                " (radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az])"
            )
        try:
            v = np.array([float(x) for x in value.split(",")])
        except ValueError:
            raise InputError(
                f"{where(path, line)}: probe: {key}: not numbers: {show(value)}"
            ) from None
        if v.size != need[key] or not np.all(np.abs(v) <= LIMIT):
            raise InputError(
                f"{where(path, line)}: probe: {key}: need {need[key]} number(s) within"
                f" +-{LIMIT:g}, got {show(value)}"
            )
        out[{"radius_m": "radius", "centre_m": "centre"}.get(key, key)] = (
            float(v[0]) if key == "radius_m" else v
        )
    if "radius" not in out or "centre" not in out:
        raise InputError(f"{where(path, line)}: probe: need radius_m=R and centre_m=cx,cy,cz")
    if not out["radius"] >= MIN_RADIUS_M:
        raise InputError(f"{where(path, line)}: probe: radius_m must be >= {MIN_RADIUS_M:g}")
    if out["axis"] is not None and not np.max(np.abs(out["axis"])) >= 1e-6:
        raise InputError(f"{where(path, line)}: probe: axis must not be (nearly) zero")
    return out


def _parse_sensor(path, line, text):
    """``noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz`` -> (6,) sigmas, both required."""
    out = {}
    for word in text.split():
        key, eq, value = word.partition("=")
        if key not in ("noise_force_N", "noise_torque_Nm") or not eq:
            raise InputError(
                f"{where(path, line)}: sensor: unknown field {show(word)}"
                " (noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz)"
            )
        try:
            v = np.array([float(x) for x in value.split(",")])
        except ValueError:
            raise InputError(
                f"{where(path, line)}: sensor: {key}: not numbers: {show(value)}"
            ) from None
        if v.size != 3 or not np.all((v >= 0) & (v <= LIMIT)):
            raise InputError(
                f"{where(path, line)}: sensor: {key}: need 3 numbers >= 0 and <= {LIMIT:g}, got"
                f" {show(value)}"
            )
        out[key] = v
    if len(out) != 2:
        raise InputError(
            f"{where(path, line)}: sensor: need noise_force_N=sx,sy,sz and noise_torque_Nm=sx,sy,sz"
        )
    return np.concatenate([out["noise_force_N"], out["noise_torque_Nm"]])


def _parse_rig(path, line, text):
    words = text.split()
    if not words or words[0] != "scara":
        raise InputError(f"{where(path, line)}: rig: only 'scara' is known, got {show(text)}")
    kv = dict(w.partition("=")[::2] for w in words[1:])
    try:
        lengths = tuple(float(kv[k]) for k in ("L1", "L2", "L3", "L4"))
    except (KeyError, ValueError):
        raise InputError(
            f"{where(path, line)}: rig: need 'scara L1=.. L2=.. L3=.. L4=..' (m), got {show(text)}"
        ) from None
    if not all(0 < v <= LIMIT for v in lengths):
        raise InputError(f"{where(path, line)}: rig: lengths must be > 0 and <= {LIMIT:g} m")
    return lengths


def _start_column(log):
    from tactile.log_clock import CLOCKS

    return CLOCKS[log.clock][0]


def _check_overlap(log):
    """Two windows of one finger that overlap make a frame's pose ambiguous."""
    for f in np.unique(log.finger):
        rows = np.flatnonzero(log.finger == f)
        rows = rows[np.argsort(log.t_start[rows], kind="stable")]
        clash = np.flatnonzero(log.t_start[rows[1:]] <= log.t_end[rows[:-1]])
        if clash.size:
            i, j = rows[clash[0]], rows[clash[0] + 1]
            raise InputError(
                f"{where(log.path, log.lines[j], _start_column(log))}: window of finger {f}"
                f" overlaps the one on line {log.lines[i]}"
            )


# --- placing frames ------------------------------------------------------------------------


def normal_sd(force, moment, centre, radius, noise):
    """RMS angle (rad) of the fingertip normal's error from sensor noise, to first order.

    ``force``, ``moment`` (n, 3) as ``sphere_contact`` takes them (sensor frame, moment about
    the sensor origin), ``noise`` (6,) independent 1-sigma errors of (F, M) (§5.1.3).  The
    normal n(w) of the line of action's entry point (§5.1.1) is differentiated by central
    differences, and sqrt(sum_j sigma_j^2 |dn/dw_j|^2) returned (n,).  At a press on the
    pole with |F| = f this is sqrt(sM_y^2 + sM_z^2 + (c + r)^2 (sF_y^2 + sF_z^2)) / (f r).
    """
    from tactile.localize.sphere import sphere_contact

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
        from tactile.localize.pipeline import scara_contacts

        lengths = log.lengths if lengths is None else lengths
        if lengths is None:
            raise InputError(
                f"{log.path}: a SCARA pose log needs its link lengths:"
                " '# rig: scara L1=.. L2=.. L3=.. L4=..' (m)"
            )
        contact, _ = scara_contacts(F, M, log.joints[rows], lengths, threshold, method)
    else:
        from tactile.localize.pipeline import posed_contacts

        probe = log.probe or {}
        c = probe.get("centre") if centre is None else centre
        r = probe.get("radius") if radius is None else radius
        ax = probe.get("axis") if axis is None else axis
        if c is None or r is None:
            raise InputError(
                f"{log.path}: no '# probe: sphere radius_m=R centre_m=cx,cy,cz' line;"
                " give the fingertip's centre and radius"
            )
        contact = posed_contacts(F, M, log.R[rows], log.t[rows], c, r, threshold, axis=ax)
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
