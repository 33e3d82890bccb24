"""``identify_run(RUN, LOG)``: a tool identified from a recording of the unloaded finger held
at the poses of a robot's pose log (``tactile payload identify``).

The recording is read with ``tactile.load_recording``; each reading's time is taken in the
log's clock (the board's stamps, or the host times of the recording's time base); the
sensor's readings are averaged within each hold (``tactile.payload.holds``) and the tool is
fitted to the means (``tactile.payload.fit.identify``).  The tool belongs to the sensor the
log's windows name and to the calibration id that sensor reported in the recording's INFO.

A log without orientations (no ``qw,qx,qy,qz``: a probe log, or any other CSV) is bad input
(``InputError``, exit 2); poses that do not determine the fit are ``DataError`` (exit 3).
"""

import numpy as np

from tactile.errors import DataError, InputError
from tactile.logs.read import GENERIC, SCARA, log_columns, read_pose_log
from tactile.payload.fit import identify
from tactile.payload.holds import TRIM, hold_means, reading_rows
from tactile.payload.orientation import ANY, Orientations
from tactile.payload.tool import GRAVITY
from tactile.recording.load import load_recording

__all__ = ["identify_run", "pose_log_with_orientations"]


def pose_log_with_orientations(path):
    """The ``PoseLog`` at ``path`` if it gives the sensor's orientation (a generic pose log's
    quaternions, or a SCARA log's joints), else InputError saying so."""
    names = set(log_columns(path))
    if not ({"qw", "qx", "qy", "qz"} <= names or set(SCARA[3:]) <= names):
        raise InputError(
            f"{path}: the log has no orientations: the sensor's pose at each hold is needed,"
            f" columns {','.join(GENERIC)}"
        )
    return read_pose_log(path)


def _sensor_of(orient, sensor, log_path):
    """The sensor to identify: ``sensor`` if given (and in the log), else the log's only one."""
    found = orient.sensors()
    if sensor is not None:
        if not orient.covers(sensor):
            raise InputError(f"{log_path}: no window of sensor {sensor} (the log has {found})")
        return int(sensor)
    if found == [ANY]:
        return 0
    if len(found) != 1:
        raise InputError(f"{log_path}: windows of sensors {found}: choose one (--sensor)")
    return found[0]


def _cal_id(rec, sensor):
    device = rec.meta.get("device")
    ids = device.get("cal_ids") if isinstance(device, dict) else None
    if not isinstance(ids, list) or sensor >= len(ids) or not isinstance(ids[sensor], int):
        raise InputError(
            f"{rec.path}: meta.json has no calibration id of sensor {sensor} (no device INFO),"
            " so the tool cannot say which calibration it was measured with"
        )
    return ids[sensor]


def identify_run(run, pose_log, sensor=None, g=GRAVITY, trim=TRIM):
    """(``Tool``, ``Holds``): the tool identified from recording ``run`` (a ``tactile
    record`` folder) held at the poses of ``pose_log`` (module docstring)."""
    log = pose_log_with_orientations(pose_log)
    orient = Orientations.from_pose_log(log)
    s = _sensor_of(orient, sensor, pose_log)
    rec = load_recording(run)
    t_us, known = rec.times_in(log.clock)
    rows = reading_rows(rec.sensor, ~rec.is_contact, s)
    rows = rows[known[rows]]
    t0, t1, R = orient.held_windows(s)
    lines = [log.lines[i] for i in _window_rows(log, s)]
    holds = hold_means(t_us[rows], rec.wrench[rows], t0, t1, R, lines, trim)
    if len(holds) == 0:
        raise DataError(
            f"{run}: no readings of sensor {s} inside the pose log's holds (a log of another"
            " run? a board streaming only contacts: tactile config --streams samples,contacts)"
        )
    source = f"{run} at the poses of {pose_log}"
    tool = identify(holds.R, holds.F, holds.T, g, s, _cal_id(rec, s), source)
    return tool, holds


def _window_rows(log, sensor):
    """The log's rows of ``sensor``'s windows in time order (``Orientations`` order)."""
    rows = np.arange(len(log)) if log.kind == "scara" else np.flatnonzero(log.finger == sensor)
    return rows[np.argsort(log.t_start[rows], kind="stable")]
