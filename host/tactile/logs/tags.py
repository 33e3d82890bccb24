"""What a robot log says before its rows: its ``# tag: ...`` lines, and its clock.

The ``# tag: ...`` lines before a robot log's header (``tactile.logs.TAGS``), read.

``scan`` finds them; ``probe``, ``rig``, ``sensor`` and ``hold`` read one each (the ``# end:``
line is the clock's: ``parse_end``).  Each error is one ``InputError``
line naming file:line, the tag and the field.

**Which clock** a robot log is stamped in, and when it ends.

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
from tactile.files.csv_dialect import preamble, show
from tactile.logs import CLOCKS, TAGS

__all__ = ["scan", "probe", "rig", "sensor", "hold"]

LIMIT = 1e6  # |value| of a position (m), angle (rad), length (m) or sensor noise (N, N*m)
MIN_RADIUS_M = 1e-6  # a fingertip's radius
MAX_HOLD_US = 2**32 - 1  # the board's clock is a 32-bit microsecond counter (PROTOCOL.md)
PROBE_USAGE = "radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az]"


def scan(path):
    """({tag: (line number, text after the colon)} of the ``# tag:`` lines before the header,
    the header's line number, the header row)."""
    comments, header_line, header = preamble(path)
    found = {}
    for no, s in comments:
        name, colon, body = s[1:].partition(":")
        if colon and name.strip() in TAGS:
            found[name.strip()] = (no, body.strip())
    return found, header_line, header


def probe(path, line, text):
    """``sphere radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az]`` -> {"radius", "centre",
    "axis" (None when not given)}: the spherical fingertip in the sensor frame."""
    words = text.split()
    if not words or words[0] != "sphere":
        raise InputError(f"{where(path, line)}: probe: only 'sphere' is known, got {show(text)}")
    sizes = {"radius_m": 1, "centre_m": 3, "axis": 3}
    got = _vectors(f"{where(path, line)}: probe", words[1:], sizes, PROBE_USAGE, -LIMIT)
    if "radius_m" not in got or "centre_m" not in got:
        raise InputError(f"{where(path, line)}: probe: need radius_m=R and centre_m=cx,cy,cz")
    out = {"radius": float(got["radius_m"][0]), "centre": got["centre_m"], "axis": got.get("axis")}
    if not out["radius"] >= MIN_RADIUS_M:
        raise InputError(f"{where(path, line)}: probe: radius_m must be >= {MIN_RADIUS_M:g}")
    if out["axis"] is not None and not np.max(np.abs(out["axis"])) >= 1e-6:
        raise InputError(f"{where(path, line)}: probe: axis must not be (nearly) zero")
    return out


def sensor(path, line, text):
    """``noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz`` -> (6,) sigmas, both required."""
    usage = "noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz"
    sizes = {"noise_force_N": 3, "noise_torque_Nm": 3}
    out = _vectors(f"{where(path, line)}: sensor", text.split(), sizes, usage, 0.0)
    if len(out) != 2:
        raise InputError(f"{where(path, line)}: sensor: need {usage}")
    return np.concatenate([out["noise_force_N"], out["noise_torque_Nm"]])


def rig(path, line, text):
    """``scara L1=.. L2=.. L3=.. L4=..`` -> the four link lengths (m) of eq. 62."""
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


def hold(path, line, text):
    """``half_width_us=N`` -> the readable time (us) on each side of a logged time."""
    at = f"{where(path, line)}: hold"
    got = _vectors(at, text.split(), {"half_width_us": 1}, "half_width_us=N", 0.0, MAX_HOLD_US)
    if not got:
        raise InputError(f"{at}: need half_width_us=N (us)")
    return float(got["half_width_us"][0])


def _vectors(at, words, sizes, usage, least, most=LIMIT):
    """{key: (sizes[key],) floats} of a tag's ``key=v,v,...`` words, each value in
    [least, most]; a one-line error prefixed ``at`` (file:line: tag) on an unknown key, a
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
        if v.size != sizes[key] or not np.all((v >= least) & (v <= most)):
            bounds = f"within +-{most:g}" if least == -most else f">= {least:g} and <= {most:g}"
            raise InputError(
                f"{at}: {key}: need {sizes[key]} number(s) {bounds}, got {show(value)}"
            )
        out[key] = v
    return out


def unit_quaternions(table, names, limit=LIMIT, path=None):
    """(q, |q|): the (n, 4) quaternion columns ``names`` (scalar first) as logged, each within
    1e-3 of unit length, else one line naming the first row that is not (exit 2)."""
    q = table.within(names, limit)
    norm = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > 1e-3)
    if bad.size:
        raise InputError(
            f"{where(path or table.path, table.lines[bad[0]], names[0])}: quaternion"
            f" ({','.join(names)}) is not unit length (|q| = {norm[bad[0]]:.6g})"
        )
    return q, norm


MAX_BOARD_US = 2**32 - 1  # the board's clock is a 32-bit microsecond counter (PROTOCOL.md)
MAX_HOST_S = 1e10  # s: UTC until the year 2286, or a monotonic clock up for 317 years
END_GRACE_S = 0.5


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
