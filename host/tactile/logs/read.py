"""A robot's logs, read: the pose log and the EP1 probe log.

**The pose log** (§5.1.1, §5.1.2): the windows in which each finger's sensor
pose is held.

The F/T wire carries no pose: the robot controller logs, per finger, time windows in which
the pose of that finger's sensor is held.  Two formats (CSV, ``#`` comment lines before the
header; the columns, comment lines and time columns are ``tactile.logs``'s, which
writes them too):

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
(``tactile.logs.tags``).  ``# end: t_us=N`` (or ``t_utc_s=``, ``t_mono_s=``) says when the
robot is done; ``tactile record`` stops there.

The log holds the poses as logged; the sensor's rotation and the CONTACT frames placed in
the world through the log are ``tactile.localize.posed``'s.

**The EP1 probe log** (§3.2, §3.3.3): per probe, a time in the hold at its start
and at its end, and the commanded rotation.

Written by the robot controller (``tactile_sim``'s ``motion_roll`` writes one through
``tactile.logs``)::

    # probe: sphere radius_m=0.01 centre_m=0.05,0,0
    # hold: half_width_us=80000          (optional: readable time on each side of a logged time)
    probe,t_start_us,t_end_us,dtheta_x,dtheta_y
    0,800000,1300000,0.5,0.0

The ``#`` lines come before the header.  The times may be in the host's clocks instead
(``t_start_utc_s,t_end_utc_s`` or ``t_start_mono_s,t_end_mono_s``), and ``# end: t_us=N``
says when the robot is done (``tactile.logs.tags``).  A log may give the sensor's
orientation in the world during each hold, ``tactile.logs.ATTITUDE`` (``qw,qx,qy,qz`` at the
probe's start, ``qw_end,qx_end,qy_end,qz_end`` at its end, scalar first), which removing a
tool's weight needs (``tactile.payload``).  The fingertip's pole is the sensor's
+x, so its ``# probe:`` line takes no ``axis=``.  The probes CSV derived from it is
``tactile.ep1.probes``'s.
"""

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from tactile import units
from tactile.errors import InputError, where
from tactile.files.csv_dialect import show
from tactile.files.tabular import read_csv
from tactile.logs import ATTITUDE, CLOCKS, COLUMNS, tags
from tactile.logs.tags import LIMIT, clock_of, parse_end, read_times

__all__ = ["PoseLog", "read_pose_log", "log_columns", "ProbeLog", "read_probe_log"]

GENERIC = COLUMNS["pose"]  # the format's columns (tactile.logs)
SCARA = COLUMNS["scara"]
MAX_FINGER = 2**31 - 1  # a sensor index (generic log) or a pass number (SCARA log)


@dataclass
class PoseLog:
    """Windows (n,) with their finger and pose; ``kind`` "pose" (``position`` (n, 3) m and
    ``quaternion`` (n, 4) qw, qx, qy, qz of unit length set) or "scara" (``joints`` (n, 4)
    set); ``probe`` = {"radius", "centre", "axis"} or None; ``lengths`` (L1, L2, L3, L4) of a
    SCARA log's ``# rig:`` line or None; ``noise`` (6,) the F/T sensor's 1-sigma noise
    (N, N*m) of a ``# sensor:`` line or None."""

    path: str
    kind: str
    t_start: np.ndarray
    t_end: np.ndarray
    finger: np.ndarray
    lines: list
    position: np.ndarray | None = None
    quaternion: np.ndarray | None = None
    joints: np.ndarray | None = None
    probe: dict | None = None
    lengths: tuple | None = None
    noise: np.ndarray | None = None
    clock: str = "board"  # of t_start/t_end (us): "board", "utc" or "monotonic"
    end_us: int | None = None  # the '# end:' line's time, in that clock

    def __len__(self):
        return len(self.t_start)


def read_pose_log(path):
    """Read a pose log (generic or SCARA, see the module docstring) into a ``PoseLog``.

    Every error is one ``InputError`` line naming file:line and the column.
    """
    units.check_stated(path, units.LOG_WORDS, units.LOG_WHAT)
    found, header_line, header = tags.scan(path)
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
    if "end" in found:
        log.end_us = parse_end(path, *found["end"], clock)
    _check_overlap(log)
    if kind == "pose":
        log.quaternion = tags.unit_quaternions(table, ("qw", "qx", "qy", "qz"), path=path)[0]
        log.position = table.within(("px", "py", "pz"), LIMIT)
    else:
        log.joints = table.within(("q1", "q2", "q3", "z"), LIMIT)
        if "rig" in found:
            log.lengths = tags.rig(path, *found["rig"])
    if "probe" in found:
        log.probe = tags.probe(path, *found["probe"])
    if "sensor" in found:
        log.noise = tags.sensor(path, *found["sensor"])
    return log


def log_columns(path):
    """The header row's column names of a robot log (after its ``#`` lines), stripped."""
    return [h.strip() for h in tags.scan(path)[2]]


def _check_overlap(log):
    """Two windows of one finger that overlap make a frame's pose ambiguous."""
    for f in np.unique(log.finger):
        rows = np.flatnonzero(log.finger == f)
        rows = rows[np.argsort(log.t_start[rows], kind="stable")]
        clash = np.flatnonzero(log.t_start[rows[1:]] <= log.t_end[rows[:-1]])
        if clash.size:
            i, j = rows[clash[0]], rows[clash[0] + 1]
            raise InputError(
                f"{where(log.path, log.lines[j], CLOCKS[log.clock][0])}: window of finger {f}"
                f" overlaps the one on line {log.lines[i]}"
            )


LOG_COLUMNS = COLUMNS["probe"]  # the format's (tactile.logs)
# (and, optional, ATTITUDE: the sensor's orientation during each end's hold)
MAX_PROBE = 2**31 - 1


class ProbeLog(NamedTuple):
    """A robot's log of EP1 probes: arrays with one row per probe."""

    path: str
    probe: np.ndarray  # (m,) int
    t_start_us: np.ndarray  # (m,) int64, a time in the hold at the probe's start
    t_end_us: np.ndarray  # (m,) int64, a time in the hold at its end
    dtheta: np.ndarray  # (m, 2) commanded rotation (x, y), contact frame at the start (eq. 29)
    radius_m: float  # fingertip radius R1
    centre_m: np.ndarray  # (3,) fingertip centre in the sensor frame
    half_width_us: float | None  # readable time on each side of a logged time, if logged
    lines: list  # source line of each row
    clock: str = "board"  # of t_start_us/t_end_us: "board", "utc" or "monotonic" (us each)
    end_us: int | None = None  # the '# end:' line's time, in that clock
    q_start: np.ndarray | None = None  # (m, 4) qw, qx, qy, qz: the sensor's orientation in
    q_end: np.ndarray | None = None  # the world during the hold at the start, at the end


def read_probe_log(path):
    """Read a probe log (module docstring); errors are one-line InputErrors naming
    file:line and column."""
    units.check_stated(path, units.LOG_WORDS, units.LOG_WHAT)
    found, header_line, header = tags.scan(path)
    fingertip = _fingertip(path, found)
    half = tags.hold(path, *found["hold"]) if "hold" in found else None
    clock = clock_of(path, header_line, {h.strip() for h in header}) or "board"
    table = read_csv(
        path, (LOG_COLUMNS[0],) + CLOCKS[clock][:2] + LOG_COLUMNS[3:], optional_float=ATTITUDE
    )
    probe = table.whole("probe", 0, MAX_PROBE)
    t_start, t_end = read_times(table, clock)
    return ProbeLog(
        str(path),
        probe,
        t_start,
        t_end,
        table.within(("dtheta_x", "dtheta_y"), LIMIT),
        fingertip["radius"],
        fingertip["centre"],
        half,
        list(table.lines),
        clock,
        parse_end(path, *found["end"], clock) if "end" in found else None,
        *_attitude(table),
    )


def _attitude(table):
    """(q_start, q_end) (m, 4) unit quaternions of the optional ``ATTITUDE`` columns, or
    (None, None); InputError on some of them only, or a quaternion not of unit length."""
    have = [c for c in ATTITUDE if c in table.columns]
    if not have:
        return None, None
    if len(have) < len(ATTITUDE):
        missing = ",".join(c for c in ATTITUDE if c not in have)
        raise InputError(f"{where(table.path, 1)}: orientation columns without {missing}")
    out = []
    for names in (ATTITUDE[:4], ATTITUDE[4:]):
        q, norm = tags.unit_quaternions(table, names, 1.0 + 1e-3)
        out.append(q / norm[:, None])
    return tuple(out)


def _fingertip(path, found):
    """The ``# probe:`` line's sphere, which a probe log must have (its pole on +x)."""
    if "probe" not in found:
        raise InputError(
            f"{where(path, 1)}: missing the '# probe: sphere radius_m=R centre_m=X,Y,Z' line"
        )
    line, text = found["probe"]
    fingertip = tags.probe(path, line, text)
    if fingertip["axis"] is not None:
        raise InputError(
            f"{where(path, line)}: probe: a probe log's fingertip has its pole on the sensor's"
            " +x; drop axis="
        )
    return fingertip
