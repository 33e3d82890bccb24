"""The ``# tag: ...`` lines before a robot log's header (``robot_log.TAGS``), read.

``scan`` finds them; ``probe``, ``rig``, ``sensor`` and ``hold`` read one each (the ``# end:``
line is the clock's: ``tactile.logs.clock.parse_end``).  Each error is one ``InputError``
line naming file:line, the tag and the field.
"""

import numpy as np

from tactile.errors import InputError, where
from tactile.files.csv_dialect import preamble, show
from tactile.logs.robot_log import TAGS

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
