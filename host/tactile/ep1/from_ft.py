"""EP1 probes from a wrist F/T sensor and the robot's probe log (§3.2, §3.3.3).

Intrinsic contact sensing (Tsujimura and Yabuta, §3.3.3): the contact on the hemispherical
fingertip lies where the force's line of action meets it (``localize.sphere_contact``, valid
with friction).  Per probe, the wrench is averaged over the CONTACT frames read while the
robot holds still at the probe's start and at its end; the two contact points, mapped back
to the fingertip parameters of eq. 20, give dp = (du, dv), and the robot's commanded rotation
gives dtheta: the rows of the probes CSV (``probes_csv``), with eq. 29's signs.

The probe log (written by the robot controller; ``tactile_sim``'s ``motion_roll`` writes one)::

    # probe: sphere radius_m=0.01 centre_m=0.05,0,0
    # hold: half_width_us=80000          (optional: readable time on each side of a logged time)
    probe,t_start_us,t_end_us,dtheta_x,dtheta_y
    0,800000,1300000,0.5,0.0

A log may also give the sensor's orientation in the world during each hold (world from
sensor, unit quaternion scalar first): ``qw,qx,qy,qz`` at the probe's start and
``qw_end,qx_end,qy_end,qz_end`` at its end, which removing a tool's weight needs
(``tactile.payload``).  The times may be in the host's clocks instead
(``t_start_utc_s,t_end_utc_s`` or ``t_start_mono_s,t_end_mono_s``), and ``# end: t_us=N``
says when the robot is done (``tactile.recording.log_clock``).

Frames: the fingertip frame has the sensor's axes, its centre at ``centre_m`` in the sensor
frame and its pole (u = v = 0 of eq. 20) along the sensor's +x.
"""

from typing import NamedTuple

import numpy as np

from tactile import units
from tactile.errors import InputError, where
from tactile.files.csv_dialect import comment_lines, preamble, show
from tactile.files.tabular import read_csv
from tactile.localize.contact import STATUS
from tactile.localize.sphere import sphere_contact
from tactile.recording.log_clock import CLOCKS, clock_of, parse_end, read_times
from tactile.recording.robot_log import ATTITUDE, COLUMNS, tag

__all__ = ["ProbeLog", "read_probe_log", "fingertip_uv", "probes_from_frames", "probe_report"]

LOG_COLUMNS = COLUMNS["probe"]  # the format's (tactile.recording.robot_log, which writes it too)
PROBE_TAG, HOLD_TAG, END_TAG = tag("probe"), tag("hold"), tag("end")
MAX_TIME_US = 2**32 - 1  # the board's clock is a 32-bit microsecond counter (PROTOCOL.md)
MAX_PROBE = 2**31 - 1
LIMIT = 1e6  # |value| of a length (m) or an angle (rad)
MIN_RADIUS_M = 1e-6  # the fingertip's radius
QUATS = ATTITUDE  # optional: the sensor's orientation in the world in each end's hold


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
    q_start: np.ndarray | None = None  # (m, 4) w, x, y, z: the sensor's orientation in the
    q_end: np.ndarray | None = None  # world during the hold at the start and at the end


def _fields(path, line_no, tokens, tag):
    out = {}
    for token in tokens:
        key, eq, value = token.partition("=")
        if not eq or not value:
            raise InputError(
                f"{where(path, line_no)}: expected key=value in {tag!r}, got {show(token)}"
            )
        out[key] = value
    return out


def _floats(path, line_no, key, text, n, limit=LIMIT):
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != n or not all(abs(v) <= limit for v in values):
        what = "a number" if n == 1 else f"{n} comma-separated numbers"
        what += f" within +-{limit:g}"
        raise InputError(f"{where(path, line_no, key)}: expected {what}, got {show(text)}")
    return values


def _header(path):
    head = comment_lines(path)
    probe = next(((i, t) for i, t in head if t.startswith(PROBE_TAG)), None)
    if probe is None:
        raise InputError(
            f"{where(path, 1)}: missing the '# probe: sphere radius_m=R centre_m=X,Y,Z' line"
        )
    line_no, text = probe
    tokens = text[len(PROBE_TAG) :].split()
    if tokens[:1] != ["sphere"]:
        raise InputError(f"{where(path, line_no)}: the probe must be 'sphere', got {show(text)}")
    f = _fields(path, line_no, tokens[1:], PROBE_TAG)
    for key in ("radius_m", "centre_m"):
        if key not in f:
            raise InputError(f"{where(path, line_no, key)}: missing in the '# probe:' line")
    (radius,) = _floats(path, line_no, "radius_m", f["radius_m"], 1)
    if radius < MIN_RADIUS_M:
        raise InputError(
            f"{where(path, line_no, 'radius_m')}: must be at least {MIN_RADIUS_M:g}, got {radius!r}"
        )
    centre = _floats(path, line_no, "centre_m", f["centre_m"], 3)
    half = None
    hold = next(((i, t) for i, t in head if t.startswith(HOLD_TAG)), None)
    if hold is not None:
        h = _fields(path, hold[0], hold[1][len(HOLD_TAG) :].split(), HOLD_TAG)
        if "half_width_us" not in h:
            raise InputError(f"{where(path, hold[0], 'half_width_us')}: missing in '# hold:'")
        (half,) = _floats(path, hold[0], "half_width_us", h["half_width_us"], 1, MAX_TIME_US)
        if half < 0.0:
            raise InputError(f"{where(path, hold[0], 'half_width_us')}: must be >= 0")
    return radius, np.array(centre), half


def read_probe_log(path):
    """Read a probe log (module docstring); errors are one-line InputErrors naming
    file:line and column."""

    units.check_stated(path, units.LOG_WORDS, units.LOG_WHAT)
    radius, centre, half = _header(path)
    _, header_line, header = preamble(path)
    clock = clock_of(path, header_line, {h.strip() for h in header}) or "board"
    table = read_csv(
        path, (LOG_COLUMNS[0],) + CLOCKS[clock][:2] + LOG_COLUMNS[3:], optional_float=QUATS
    )
    probe = table.whole("probe", 0, MAX_PROBE)
    t_start, t_end = read_times(table, clock)
    end = next(((i, t) for i, t in comment_lines(path) if t.startswith(END_TAG)), None)
    return ProbeLog(
        str(path),
        probe,
        t_start,
        t_end,
        table.within(("dtheta_x", "dtheta_y"), LIMIT),
        radius,
        centre,
        half,
        list(table.lines),
        clock,
        None if end is None else parse_end(path, end[0], end[1][len(END_TAG) :], clock),
        *_orientations(table),
    )


def _orientations(table):
    """(q_start, q_end) (m, 4) unit quaternions of the optional columns, or (None, None);
    InputError on half of them or a quaternion that is not of unit length."""
    have = [c for c in QUATS if c in table.columns]
    if not have:
        return None, None
    if len(have) < len(QUATS):
        missing = ",".join(c for c in QUATS if c not in have)
        raise InputError(f"{where(table.path, 1)}: orientation columns without {missing}")
    out = []
    for names in (QUATS[:4], QUATS[4:]):
        q = table.within(names, 1.0 + 1e-3)
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > 1e-3)
        if bad.size:
            raise InputError(
                f"{where(table.path, table.lines[bad[0]], names[0])}: quaternion"
                f" ({','.join(names)}) is not unit length (|q| = {norm[bad[0]]:.6g})"
            )
        out.append(q / norm[:, None])
    return tuple(out)


def fingertip_uv(point, radius):
    """Inverse of eq. 20 for points (..., 3) in the fingertip frame (centre at the origin):
    u = asin(z / R1) (clamped), v = atan2(-y, x)."""
    p = np.asarray(point, float)
    u = np.arcsin(np.clip(p[..., 2] / radius, -1.0, 1.0))
    v = np.arctan2(-p[..., 1], p[..., 0])
    return np.stack([u, v], axis=-1)


def _windows(log, t_us, average, half_width_us):
    """Per probe and end, the indices of the frames to average (list of (m, 2) index arrays)."""
    t = np.asarray(t_us, np.int64)
    half = log.half_width_us if half_width_us is None else float(half_width_us)
    if half is None:
        if average is None or len(t) < 2:
            raise InputError(f"{log.path}: no '# hold: half_width_us=' line: give an average")
        half = 0.5 * average * float(np.median(np.diff(np.sort(t))))
    order = np.argsort(t, kind="stable")
    ts = t[order]
    picks = []
    for times in (log.t_start_us, log.t_end_us):
        lo = np.searchsorted(ts, times - half, side="left")
        hi = np.searchsorted(ts, times + half, side="right")
        row = []
        for a, b, tc in zip(lo, hi, times, strict=True):
            idx = order[a:b]
            if average is not None and len(idx) > average:
                near = np.argsort(np.abs(ts[a:b] - tc), kind="stable")[:average]
                idx = order[a:b][np.sort(near)]
            row.append(idx)
        picks.append(row)
    return list(zip(*picks, strict=True)), half


def _derive(log, t_us, wrench, threshold, average, half_width_us):

    if average is not None and (int(average) != average or average < 1):
        raise InputError(f"average: expected a whole number >= 1, got {average!r}")
    w = np.asarray(wrench, float).reshape(-1, 6)
    if len(w) != len(np.ravel(t_us)):
        raise InputError(f"frames: {len(np.ravel(t_us))} timestamps but {len(w)} wrenches")
    picks, half = _windows(log, np.ravel(t_us), average, half_width_us)
    m = len(log.probe)
    mean = np.zeros((m, 2, 6))
    count = np.zeros((m, 2), int)
    for i, ends in enumerate(picks):
        for e, idx in enumerate(ends):
            count[i, e] = len(idx)
            if len(idx):
                mean[i, e] = w[idx].mean(axis=0)
    c = sphere_contact(
        mean[..., :3], mean[..., 3:], log.centre_m, log.radius_m, threshold, axis=(1.0, 0.0, 0.0)
    )
    uv = fingertip_uv(c.point - log.centre_m, log.radius_m)
    usable = (count > 0).all(axis=1) & c.usable.all(axis=1)
    rows = np.concatenate([log.dtheta, uv[:, 1] - uv[:, 0]], axis=1)
    rows = np.where(usable[:, None], rows, 0.0)
    status = []
    for i in range(m):
        why = "ok"
        for e, name in enumerate(("t_start_us", "t_end_us")):
            t = (log.t_start_us, log.t_end_us)[e][i]
            if count[i, e] == 0:
                why = f"no frames within {half:g} us of {name}={t}"
            elif not c.usable[i, e]:
                why = f"wrench at {name}={t} not localised ({STATUS[c.status[i, e]]})"
            if why != "ok":
                break
        status.append(f"probe {int(log.probe[i])} (line {log.lines[i]}): {why}")
    return rows, usable, status, count


def probes_from_frames(log, t_us, wrench, threshold=0.0, average=None, half_width_us=None):
    """Probes CSV rows from recorded CONTACT frames and a ``ProbeLog``.

    ``t_us`` (n,) frame timestamps, ``wrench`` (n, 6) in N and N*m (sensor frame).  Per probe
    end, the frames within the hold window (``half_width_us``, default the log's) around the
    logged time are averaged (only the ``average`` nearest, if given), localised on the
    fingertip (``sphere_contact``; |F| <= ``threshold`` is no contact) and mapped to (u, v) of
    eq. 20.  Returns (rows (m, 4) of dtheta_x, dtheta_y, du, dv; usable (m,) bool).  A probe
    without frames in a window, or whose wrench does not localise, is not usable and its row is
    zeros (``probe_report`` says why).
    """
    rows, usable, _, _ = _derive(log, t_us, wrench, threshold, average, half_width_us)
    return rows, usable


def probe_report(log, t_us, wrench, threshold=0.0, average=None, half_width_us=None):
    """One line per probe: 'probe N (line L): ok' or why it is not usable, and frames used."""
    _, _, status, count = _derive(log, t_us, wrench, threshold, average, half_width_us)
    return [f"{s}; frames {a}+{b}" for s, (a, b) in zip(status, count, strict=True)]
