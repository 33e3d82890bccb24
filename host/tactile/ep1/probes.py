"""EP1 probes from a wrist F/T sensor and the robot's probe log (§3.2, §3.3.3).

Intrinsic contact sensing (Tsujimura and Yabuta, §3.3.3): the contact on the hemispherical
fingertip lies where the force's line of action meets it (``localize.sphere_contact``, valid
with friction).  Per probe, the wrench is averaged over the CONTACT frames read while the
robot holds still at the probe's start and at its end; the two contact points, mapped back
to the fingertip parameters of eq. 20, give dp = (du, dv), and the robot's commanded rotation
gives dtheta: the rows of the probes CSV (below), with eq. 29's signs.

The probe log (its format, clocks and reader: ``tactile.logs.read``) gives, per probe, a
time in the hold at its start and at its end, the commanded rotation and the fingertip.

Frames: the fingertip frame has the sensor's axes, its centre at ``centre_m`` in the sensor
frame and its pole (u = v = 0 of eq. 20) along the sensor's +x.

**The EP1 probes CSV contract.**

A ``# units: rad`` line (a file without it is read as before), a header row; required
columns ``dtheta_x,dtheta_y,du,dv``: the net rotation of the finger about the x and y axes
of the contact frame (rad) and the change of the contact point in the fingertip parameters
of eq. 20 (rad), with the signs of eq. 29: M1 dp = (K1 + K2~)^-1 [-dtheta_y,
dtheta_x]^T.  Other columns are ignored; ``#`` lines are comments.
"""

import numpy as np

from tactile import units
from tactile.errors import InputError
from tactile.files.tabular import read_csv
from tactile.localize.contact import STATUS
from tactile.localize.probes import sphere_contact

__all__ = [
    "fingertip_uv",
    "probes_from_frames",
    "probe_report",
    "COLUMNS",
    "read_probes",
    "format_probes",
]


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
    """Probes CSV rows from recorded CONTACT frames and a ``ProbeLog`` (``tactile.logs.read``).

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


COLUMNS = ("dtheta_x", "dtheta_y", "du", "dv")


def read_probes(path):
    """Return (dtheta (m, 2), dp (m, 2)) arrays; errors are InputError naming file:line:column."""
    units.check_stated(path, {units.PROBES}, "a probes CSV holds angles in rad")
    table = read_csv(path, COLUMNS)
    data = table.array(*COLUMNS)
    return data[:, :2], data[:, 2:]


def format_probes(rows):
    """CSV text for an (m, 4) array of (dtheta_x, dtheta_y, du, dv) rows (repr precision)."""
    lines = [units.line(units.PROBES).rstrip("\n"), ",".join(COLUMNS)]
    lines += [",".join(repr(float(x)) for x in row) for row in rows]
    return "\n".join(lines) + "\n"
