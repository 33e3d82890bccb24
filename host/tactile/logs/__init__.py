"""The robot's logs beside a recording, as files: their formats, below every reader and writer.

- here: the pose, SCARA-joint and probe logs' format (columns, units line, comment tags,
  the writer, below); the simulator's robots write through it;
- ``tags``: the ``# tag:`` lines before a log's header, and which clock its times
  are in and when it ends;
- ``read``: the readers, a ``PoseLog`` (``tactile.localize`` places contacts in
  the world through it) and a ``ProbeLog`` (``tactile.ep1.probes`` makes probes of it).

Nothing here imports the rest of the host but its vocabulary (``tactile.units``,
``tactile.errors``) and its file readers (``tactile.files``).

**The robot logs' format**: one owner for the writer (the simulator's robots) and the readers.

The F/T wire carries no pose, so a robot controller logs what it did beside the recording
(§5.1.1-5.1.2, §3.2).  Three kinds, all CSV with ``#`` comment lines before the header:

- ``pose`` (any robot; read by ``tactile.logs.read``): per finger, a window in which
  its sensor frame's pose in the world is held, ``px,py,pz`` (m) and the unit quaternion
  ``qw,qx,qy,qz`` (scalar first);
- ``scara`` (the ch. 5 rig, eq. 62; read by ``tactile.logs.read``): joint angles
  ``q1,q2,q3`` (rad) and height ``z`` (m) per window; ``finger`` is the pass;
- ``probe`` (EP1 through a wrist F/T sensor; read by ``tactile.logs.read``): per probe a
  time in the hold at its start and at its end, and the commanded rotation (rad); optionally
  (``ATTITUDE``) the sensor's orientation in the world during those holds, unit quaternions
  ``qw,qx,qy,qz`` (start) and ``qw_end,qx_end,qy_end,qz_end`` (end), world from sensor,
  scalar first.  A reader that does not need them ignores them.

Times name their clock (``CLOCKS``): the board's (``t_start_us,t_end_us``), UTC or the
recording host's monotonic clock (seconds; ``tactile.logs.tags`` reads them, and the
recording's time base joins them to the frames).  Comment lines (``TAGS``, read by
``tactile.logs.tags``): ``# probe: sphere radius_m=R centre_m=cx,cy,cz [axis=ax,ay,az]``
(the fingertip in the sensor frame), ``# rig: scara L1=.. L2=.. L3=.. L4=..`` (m),
``# sensor: noise_force_N=sx,sy,sz noise_torque_Nm=sx,sy,sz`` (1 sigma per axis),
``# hold: half_width_us=N`` and ``# end: t_us=N`` (or ``t_utc_s=``, ``t_mono_s=``: when the
robot is done), all before the header.  Line 1 is the units line (``UNITS``).  Numbers are
written with ``repr``, so a reader gets back the very floats the writer had.
"""

from tactile import units
from tactile.files.writing import atomic_write

__all__ = [
    "ATTITUDE",
    "CLOCKS",
    "COLUMNS",
    "KINDS",
    "TAGS",
    "TIME_COLUMNS",
    "UNITS",
    "columns",
    "format_row",
    "tag",
    "tag_lines",
    "write_log",
]

# clock -> (start column, end column, the '# end:' line's key)
CLOCKS = {
    "board": ("t_start_us", "t_end_us", "t_us"),
    "utc": ("t_start_utc_s", "t_end_utc_s", "t_utc_s"),
    "monotonic": ("t_start_mono_s", "t_end_mono_s", "t_mono_s"),
}
TIME_COLUMNS = {c for cols in CLOCKS.values() for c in cols[:2]}

# kind -> (columns before the times, columns after them)
_AROUND = {
    "pose": ((), ("finger", "px", "py", "pz", "qw", "qx", "qy", "qz")),
    "scara": ((), ("finger", "q1", "q2", "q3", "z")),
    "probe": (("probe",), ("dtheta_x", "dtheta_y")),
}
KINDS = tuple(_AROUND)
# optional columns after a probe log's: the sensor's orientation during each end's hold
ATTITUDE = ("qw", "qx", "qy", "qz", "qw_end", "qx_end", "qy_end", "qz_end")
# kind -> its header in the board's clock
COLUMNS = {k: (*pre, *CLOCKS["board"][:2], *post) for k, (pre, post) in _AROUND.items()}
# kind -> its units line's spec: times, then the rest (the quaternion has no unit)
UNITS = {"pose": "us, m", "scara": "us, rad, m", "probe": "us, rad, m"}
TAGS = ("probe", "rig", "sensor", "hold", "end")


def columns(kind, clock="board"):
    """The header of a ``kind`` log whose times are in ``clock``."""
    pre, post = _AROUND[kind]
    return (*pre, *CLOCKS[clock][:2], *post)


def tag(name):
    """The start of a ``name`` comment line, e.g. ``# probe:``."""
    return f"# {name}:"


def format_row(row):
    """One data line (no newline): each value's ``repr``, comma-separated."""
    return ",".join(repr(v) for v in row)


def _numbers(values):
    return ",".join(repr(float(v)) for v in values)


def _probe_line(radius_m, centre_m, axis=None):
    text = f"sphere radius_m={float(radius_m)!r} centre_m={_numbers(centre_m)}"
    return text if axis is None else f"{text} axis={_numbers(axis)}"


def _end_value(clock, t_us):
    """The '# end:' value: whole board microseconds, or a host clock's seconds."""
    return str(round(t_us)) if clock == "board" else repr(t_us / 1e6)


def tag_lines(*, probe=None, rig=None, sensor=None, hold_us=None, end_us=None, clock="board"):
    """The comment lines (module docstring) for the fields given, in ``TAGS`` order."""
    text = {}
    if probe is not None:
        text["probe"] = _probe_line(*probe)
    if rig is not None:
        text["rig"] = "scara " + " ".join(f"L{i + 1}={float(v)!r}" for i, v in enumerate(rig))
    if sensor is not None:
        s = [float(v) for v in sensor]
        text["sensor"] = f"noise_force_N={_numbers(s[:3])} noise_torque_Nm={_numbers(s[3:])}"
    if hold_us is not None:
        text["hold"] = f"half_width_us={hold_us!r}"
    if end_us is not None:
        text["end"] = f"{CLOCKS[clock][2]}={_end_value(clock, end_us)}"
    return [f"{tag(name)} {text[name]}\n" for name in TAGS if name in text]


def write_log(path, kind, rows, clock="board", more=(), **fields):
    """Write a ``kind`` log (module docstring) of ``rows`` (tuples in ``columns(kind, clock)``
    order, then the optional columns ``more`` names, e.g. ``ATTITUDE``) to ``path``.

    ``fields`` (each written only when given): ``probe`` = (radius_m, centre_m[, axis]);
    ``rig`` = (L1, L2, L3, L4) in m; ``sensor`` = six 1-sigma noises (N, N*m); ``hold_us`` the
    readable half width of a hold; ``end_us`` when the robot is done, in us of ``clock``.
    """
    head = tag_lines(clock=clock, **fields)
    with atomic_write(path, text=True) as fh:
        fh.write(units.line(UNITS[kind]))
        fh.writelines(head)
        fh.write(",".join((*columns(kind, clock), *more)) + "\n")
        fh.writelines(format_row(row) + "\n" for row in rows)
