"""A robot's pose log, read (§5.1.1, §5.1.2): the windows in which each finger's sensor
pose is held.

The F/T wire carries no pose: the robot controller logs, per finger, time windows in which
the pose of that finger's sensor is held.  Two formats (CSV, ``#`` comment lines before the
header; the columns, comment lines and time columns are ``tactile.logs.robot_log``'s, which
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
(``tactile.logs.clock``).  ``# end: t_us=N`` (or ``t_utc_s=``, ``t_mono_s=``) says when the
robot is done; ``tactile record`` stops there.

The log holds the poses as logged; the sensor's rotation and the CONTACT frames placed in
the world through the log are ``tactile.localize.posed``'s.
"""

from dataclasses import dataclass

import numpy as np

from tactile import units
from tactile.errors import InputError, where
from tactile.files.csv_dialect import show
from tactile.files.tabular import read_csv
from tactile.logs import robot_log, tags
from tactile.logs.clock import CLOCKS, clock_of, parse_end, read_times
from tactile.logs.tags import LIMIT

__all__ = ["PoseLog", "read_pose_log", "log_columns"]

GENERIC = robot_log.COLUMNS["pose"]  # the format's columns (tactile.logs.robot_log)
SCARA = robot_log.COLUMNS["scara"]
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
