"""``tactile.load_recording(DIR, payload=, pose_log=)``: a recording (``tactile.recording.load``)
with its tools' weight and the bias removed, as ``record --payload`` does for its files.

Each tool (a ``Tool`` or a tool.json path) is checked against the recorded board's sensor
and calibration; the robot log gives every row's orientation; the host tares, tracks the
drift and gates contacts again (``tactile.payload.compensator``) over the whole recording.
"""

import numpy as np

from tactile.errors import InputError
from tactile.payload.compensator import Compensator
from tactile.payload.orientation import read_log
from tactile.payload.tool import Tool, check_device, read_tool, tool_doc
from tactile.recording import load as recording

__all__ = ["compensate_recording", "load_recording"]


def load_recording(path, payload=None, pose_log=None):
    """The ``tactile record`` directory ``path`` as a ``RecordingData``
    (``tactile.recording.load``); with ``payload`` (a ``Tool`` or a tool.json path, or a
    list of them) their weight and the drifting bias removed through the robot log
    ``pose_log`` (default: the one the recording's command names): ``compensate_recording``.

    Raises ``tactile.errors.InputError`` (a ``ValueError``) naming the file, line and column
    of anything malformed, or a tool of another sensor or calibration."""
    rec = recording.load_recording(path)
    if payload is None:
        return rec
    return compensate_recording(
        rec, payload, recording.robot_log_of(rec) if pose_log is None else pose_log
    )


def _tools(payload, device):
    """[(name, Tool)] of ``payload`` (a Tool, a path, or a list of them), each checked
    against the recorded board's sensor and calibration."""
    given = payload if isinstance(payload, list | tuple) else [payload]
    tools = [(str(t), read_tool(t)) if not isinstance(t, Tool) else ("payload", t) for t in given]
    for name, tool in tools:
        check_device(tool, device, name)
    return tools


def compensate_recording(rec, payload, pose_log):
    """``rec`` (a ``RecordingData``) with the tools' weight and bias removed: ``force_N`` and
    ``torque_Nm`` compensated, frames.csv's kept as ``raw_force_N``, ``raw_torque_Nm``, the
    host's gate in ``host_phase``, ``host_contact_id``, and ``payload`` what was done."""
    tools = _tools(payload, rec.meta.get("device"))
    if pose_log is None:
        raise InputError(
            f"{rec.path}: the payload needs the robot log (the sensor's orientation at each"
            " reading): give pose_log="
        )
    log, orient = read_log(pose_log)
    t_us, known = rec.times_in(log.clock)
    comp = Compensator([t for _, t in tools], orient, rec.meta.get("device"))
    rows = np.flatnonzero(known)
    sensor, sample = rec.sensor[rows], ~rec.is_contact[rows]
    comp.prime(sensor, sample, t_us[rows], rec.wrench[rows])
    W, phase, cid = rec.wrench, rec.phase.copy(), rec.contact_id.copy()
    W[rows], phase[rows], cid[rows] = comp.arrays(
        sensor, sample, t_us[rows], rec.wrench[rows], rec.phase[rows], rec.contact_id[rows]
    )
    comp.flush()
    rec.raw_force_N, rec.raw_torque_Nm = rec.force_N, rec.torque_Nm
    rec.force_N, rec.torque_Nm = W[:, :3], W[:, 3:]
    rec.host_phase, rec.host_contact_id = phase, cid
    docs = [{"file": name, "tool": tool_doc(tool)} for name, tool in tools]
    rec.payload = {"tools": docs, "pose_log": str(pose_log), "compensation": comp.report()}
    return rec
