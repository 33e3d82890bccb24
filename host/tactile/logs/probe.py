"""A robot's EP1 probe log, read (§3.2, §3.3.3): per probe, a time in the hold at its start
and at its end, and the commanded rotation.

Written by the robot controller (``tactile_sim``'s ``motion_roll`` writes one through
``tactile.logs.robot_log``)::

    # probe: sphere radius_m=0.01 centre_m=0.05,0,0
    # hold: half_width_us=80000          (optional: readable time on each side of a logged time)
    probe,t_start_us,t_end_us,dtheta_x,dtheta_y
    0,800000,1300000,0.5,0.0

The ``#`` lines come before the header.  The times may be in the host's clocks instead
(``t_start_utc_s,t_end_utc_s`` or ``t_start_mono_s,t_end_mono_s``), and ``# end: t_us=N``
says when the robot is done (``tactile.logs.clock``).  A log may give the sensor's
orientation in the world during each hold, ``robot_log.ATTITUDE`` (``qw,qx,qy,qz`` at the
probe's start, ``qw_end,qx_end,qy_end,qz_end`` at its end, scalar first), which removing a
tool's weight needs (``tactile.payload``).  The fingertip's pole is the sensor's
+x, so its ``# probe:`` line takes no ``axis=``.  The probes CSV derived from it is
``tactile.ep1.from_ft``'s.
"""

from typing import NamedTuple

import numpy as np

from tactile import units
from tactile.errors import InputError, where
from tactile.files.tabular import read_csv
from tactile.logs import robot_log, tags
from tactile.logs.clock import CLOCKS, clock_of, parse_end, read_times
from tactile.logs.tags import LIMIT

__all__ = ["ProbeLog", "read_probe_log"]

LOG_COLUMNS = robot_log.COLUMNS["probe"]  # the format's (tactile.logs.robot_log)
ATTITUDE = robot_log.ATTITUDE  # optional: the sensor's orientation during each end's hold
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
