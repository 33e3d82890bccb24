"""A robot's pose log, and CONTACT frames placed in the world through it (§5.1.1, §5.1.2).

The F/T wire carries no pose: the robot controller logs, per finger, time windows in which
the pose of that finger's sensor is held.  Two formats (CSV, ``#`` comment lines allowed; the
columns, comment lines and time columns are ``tactile.recording.robot_log``'s, which writes them
too):

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
(``tactile.recording.log_clock``).  ``# end: t_us=N`` (or ``t_utc_s=``, ``t_mono_s=``) says when the
robot is done; ``tactile record`` stops there.

Placing CONTACT frames in the world through a log: ``tactile.localize.posed``.
"""

from dataclasses import dataclass

import numpy as np

from tactile import units
from tactile.errors import InputError, where
from tactile.files.tabular import show
from tactile.recording import robot_log

__all__ = ["PoseLog", "read_pose_log", "log_columns"]

GENERIC = robot_log.COLUMNS["pose"]  # the format's columns (tactile.recording.robot_log)
SCARA = robot_log.COLUMNS["scara"]
MAX_FINGER = 2**31 - 1  # a sensor index (generic log) or a pass number (SCARA log)
LIMIT = 1e6  # |value| of a position (m), angle (rad), length (m) or sensor noise (N, N*m)
MIN_RADIUS_M = 1e-6  # a fingertip's radius


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


# --- reading -------------------------------------------------------------------------------


def read_pose_log(path):
    """Read a pose log (generic or SCARA, see the module docstring) into a ``PoseLog``.

    Every error is one ``InputError`` line naming file:line and the column.
    """
    from tactile.files.tabular import read_csv
    from tactile.recording.log_clock import CLOCKS, clock_of, parse_end, read_times

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
    from tactile.files.csv_dialect import preamble

    comments, header_line, header = preamble(path)
    tags = {}
    for no, s in comments:
        tag, colon, body = s[1:].partition(":")
        if colon and tag.strip() in robot_log.TAGS:
            tags[tag.strip()] = (no, body.strip())
    return tags, header_line, header


def _parse_probe(path, line, text):
    """``sphere radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az]`` -> radius, centre, axis."""
    words = text.split()
    if not words or words[0] != "sphere":
        raise InputError(f"{where(path, line)}: probe: only 'sphere' is known, got {show(text)}")
    usage = "radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az]"
    sizes = {"radius_m": 1, "centre_m": 3, "axis": 3}
    got = _vectors(f"{where(path, line)}: probe", words[1:], sizes, usage, -LIMIT)
    if "radius_m" not in got or "centre_m" not in got:
        raise InputError(f"{where(path, line)}: probe: need radius_m=R and centre_m=cx,cy,cz")
    out = {"radius": float(got["radius_m"][0]), "centre": got["centre_m"], "axis": got.get("axis")}
    if not out["radius"] >= MIN_RADIUS_M:
        raise InputError(f"{where(path, line)}: probe: radius_m must be >= {MIN_RADIUS_M:g}")
    if out["axis"] is not None and not np.max(np.abs(out["axis"])) >= 1e-6:
        raise InputError(f"{where(path, line)}: probe: axis must not be (nearly) zero")
    return out


def _parse_sensor(path, line, text):
    """``noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz`` -> (6,) sigmas, both required."""
    usage = "noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz"
    sizes = {"noise_force_N": 3, "noise_torque_Nm": 3}
    out = _vectors(f"{where(path, line)}: sensor", text.split(), sizes, usage, 0.0)
    if len(out) != 2:
        raise InputError(f"{where(path, line)}: sensor: need {usage}")
    return np.concatenate([out["noise_force_N"], out["noise_torque_Nm"]])


def _vectors(at, words, sizes, usage, least):
    """{key: (sizes[key],) floats} of a header tag's ``key=v,v,...`` words, each value in
    [least, LIMIT]; a one-line error prefixed ``at`` (file:line: tag) on an unknown key, a
    non-number or a wrong count or range."""
    out = {}
    for word in words:
        key, eq, value = word.partition("=")
        if key not in sizes or not eq:
            raise InputError(f"{at}: unknown field {show(word)} ({usage})")
        try:
            v = np.array([float(x) for x in value.split(",")])
        except ValueError:
            raise InputError(f"{at}: {key}: not numbers: {show(value)}") from None
        if v.size != sizes[key] or not np.all((v >= least) & (v <= LIMIT)):
            bounds = f"within +-{LIMIT:g}" if least == -LIMIT else f">= {least:g} and <= {LIMIT:g}"
            raise InputError(
                f"{at}: {key}: need {sizes[key]} number(s) {bounds}, got {show(value)}"
            )
        out[key] = v
    return out


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
    from tactile.recording.log_clock import CLOCKS

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
