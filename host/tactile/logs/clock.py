"""Which clock a robot log is stamped in, and when it ends.

A pose or probe log names its clock by its time columns:

- ``t_start_us,t_end_us``: the board's clock (the stamps of its frames; 32-bit us);
- ``t_start_utc_s,t_end_utc_s``: UTC as Unix time in seconds (ROS ``header.stamp``, a
  controller's wall clock kept by NTP or PTP);
- ``t_start_mono_s,t_end_mono_s``: the recording host's monotonic clock in seconds
  (CLOCK_MONOTONIC: ROS steady time, for a robot logging on the same computer).

A host-clock log is joined to the frames through the recording's time base (``meta.json``,
``tactile.recording.timebase``).  Inside, every time is held as whole microseconds (int64)
of its clock.

A log may say when its robot is done with ``# end: t_us=N`` (or ``t_utc_s=``, ``t_mono_s=``,
in the log's own clock): ``tactile record`` stops once that time has passed.  Without it,
the recording stops ``END_GRACE_S`` after the log's last entry, time for the contacts' END
frames.  The emulator writes the line with its scene's end.
"""

import numpy as np

from tactile.errors import InputError, where
from tactile.files.csv_dialect import show
from tactile.logs import robot_log

MAX_BOARD_US = 2**32 - 1  # the board's clock is a 32-bit microsecond counter (PROTOCOL.md)
MAX_HOST_S = 1e10  # s: UTC until the year 2286, or a monotonic clock up for 317 years
END_GRACE_S = 0.5

# clock -> (start column, end column, the '# end:' line's key): the format's (robot_log)
CLOCKS = robot_log.CLOCKS
TIME_COLUMNS = robot_log.TIME_COLUMNS


def clock_of(path, line, names):
    """The clock whose two time columns ``names`` (the header's) hold; one line if none or
    several do."""
    found = [k for k, cols in CLOCKS.items() if set(cols[:2]) <= set(names)]
    if len(found) == 1:
        return found[0]
    pairs = " or ".join(",".join(c[:2]) for c in CLOCKS.values())
    if not found:
        return None
    raise InputError(
        f"{where(path, line)}: time columns of two clocks ({' and '.join(found)}); keep one"
        f" pair: {pairs}"
    )


def read_times(table, clock):
    """(start, end) whole microseconds (int64) in ``clock``, checked: range and order."""
    start_col, end_col, _ = CLOCKS[clock]
    if clock == "board":
        start, end = (table.whole(c, 0, MAX_BOARD_US) for c in (start_col, end_col))
    else:
        start, end = (_host_us(table, c) for c in (start_col, end_col))
    bad = np.flatnonzero(end < start)
    if bad.size:
        raise InputError(
            f"{where(table.path, table.lines[bad[0]], end_col)}: ends before {start_col}"
        )
    return start, end


def _host_us(table, name):
    v = np.asarray(table.columns[name], dtype=float)
    bad = np.flatnonzero(~((v >= 0) & (v <= MAX_HOST_S)))
    if bad.size:
        i = int(bad[0])
        raise InputError(
            f"{where(table.path, table.lines[i], name)}: must be a time in 0..{MAX_HOST_S:g} s,"
            f" got {float(v[i])!r}"
        )
    return np.round(v * 1e6).astype(np.int64)


def parse_end(path, line, text, clock):
    """``# end: KEY=VALUE`` -> whole microseconds in ``clock`` (KEY must be the clock's)."""
    key = CLOCKS[clock][2]
    name, eq, value = text.strip().partition("=")
    if name.strip() != key or not eq:
        raise InputError(
            f"{where(path, line)}: end: expected '{key}=...' (this log is in the {clock} clock),"
            f" got {show(text)}"
        )
    try:
        v = float(value)
    except ValueError:
        v = float("nan")
    if clock == "board":
        ok = v == v and v == round(v) and 0 <= v <= MAX_BOARD_US
        if not ok:
            raise InputError(f"{where(path, line)}: end: {key} must be 0..{MAX_BOARD_US}")
        return int(v)
    if not 0 <= v <= MAX_HOST_S:
        raise InputError(f"{where(path, line)}: end: {key} must be a time in 0..{MAX_HOST_S:g} s")
    return int(round(v * 1e6))


def log_end(t_end, end_us):
    """(end in us of the log's clock, how it was found) for ``tactile record``."""
    if end_us is not None:
        return int(end_us), "its '# end:' line"
    return int(np.max(t_end)) + int(END_GRACE_S * 1e6), f"{END_GRACE_S:g} s after its last entry"


def show_time(clock, us):
    """A time of ``clock`` for a message: board seconds, or the host clock's seconds."""
    if clock == "utc":
        from datetime import UTC, datetime

        return datetime.fromtimestamp(us / 1e6, UTC).isoformat(timespec="milliseconds")
    return f"{'board' if clock == 'board' else 'monotonic'} {us / 1e6:.3f} s"
