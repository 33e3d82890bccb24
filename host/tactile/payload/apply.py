"""The compensator where the readings are: a live stream, a run on the board, a recording.

**A live stream**: a tool's weight removed batch by batch (``tactile live`` and ``record
--foxglove`` with ``--payload``): what the terminal and Foxglove show is the compensated
wrench, and the contact state is the host's gate's.

Each frame's time in the pose log's clock: the board's stamp, or for a log in a host clock
the host time the recorder gave it, else its arrival (``tactile live``: within the link's
delay, a few ms).  The host tares at the first steady stretch of the stream (the finger
free, as a TARE wants); until then the tool's identified bias is used.

**What ``record --payload`` asks of the board** (``tactile.recording.session.Session``).

- Each tool must be for a sensor of this board, measured with the calibration that sensor
  reports (``check``): a run refused here leaves nothing behind.
- Removing a tool's weight and gating contacts again needs every reading, so the SAMPLE
  stream is switched on for the run (``samples_on``: not persisted) and the board's
  configuration put back at its end (``put_back``).
- meta.json's "payload" says which tools, and whether the stream was switched on (``meta``).

**``tactile.load_recording(DIR, payload=, pose_log=)``**: a recording (``tactile.recording.load``)
with its tools' weight and the bias removed, as ``record --payload`` does for its files.

Each tool (a ``Tool`` or a tool.json path) is checked against the recorded board's sensor
and calibration; the robot log gives every row's orientation; the host tares, tracks the
drift and gates contacts again (``tactile.payload.compensator``) over the whole recording.
"""

import contextlib
import time

import numpy as np

from tactile.board.client import info_dict
from tactile.errors import BoardError, InputError
from tactile.payload.compensator import Compensator
from tactile.payload.orientation import read_log
from tactile.payload.tool import Tool, check_device, read_tool, tool_doc
from tactile.recording import load as recording
from tactile_protocol import constants as C
from tactile_protocol.settings import to_newtons

__all__ = ["Following", "OnBoard", "compensate_recording", "load_recording"]


class Following:
    """``tools`` (``Tool`` list) compensated through ``orient`` (``Orientations``) for a log
    in ``clock`` ("board", "utc" or "monotonic"); the board's INFO comes with the first batch."""

    def __init__(self, tools, orient, clock="board", samples=None):
        self.named = (
            [(str(p), t) for p, t in tools] if tools and isinstance(tools[0], tuple) else None
        )
        self.tools = [t for _, t in tools] if self.named else list(tools)
        self.orient, self.clock, self.samples = orient, clock, samples
        self.comp = None
        self.utc_minus_mono = time.time() - time.monotonic()

    def check(self, device):
        """InputError unless each tool is for a sensor of ``device`` (a board's INFO as a
        dict) with the calibration it was measured with."""
        for name, tool in self.named or [("payload", t) for t in self.tools]:
            check_device(tool, device, name)

    def _times(self, msgs, host_times, arrivals):
        if self.clock == "board":
            return None
        k = 1 if self.clock == "utc" else 0
        if host_times is not None:
            return [-1 if t is None else round(t[k] * 1e6) for t in host_times]
        shift = self.utc_minus_mono if k else 0.0
        return [
            -1 if a is None else round((a + shift) * 1e6) for a in arrivals or [None] * len(msgs)
        ]

    def feed(self, msgs, device, host_times=None, arrivals=None):
        """(frames, host_times, arrivals) of one batch, each list re-cut to the frames out."""
        if self.comp is None:
            dev = dict(device or {})
            if self.samples is not None:
                dev["streams"] = ["samples", "contacts"] if self.samples else ["contacts"]
            self.comp = Compensator(self.tools, self.orient, dev)
        out, index = self.comp.messages(msgs, self._times(msgs, host_times, arrivals))
        pick = index.tolist()
        host = None if host_times is None else [host_times[i] for i in pick]
        arrived = None if arrivals is None else [arrivals[i] for i in pick]
        return out, host, arrived

    def report(self):
        return [] if self.comp is None else self.comp.report()


class OnBoard:
    """The tools ``[(tool.json's path, Tool)]`` of one recording."""

    def __init__(self, tools):
        self.tools = list(tools)
        self.refused = False  # the board is not the tools': the run leaves nothing
        self.restore = None  # CONFIG values to put back (the SAMPLE stream switched on)

    def __bool__(self):
        return bool(self.tools)

    def check(self, client):
        """InputError unless the board of ``client`` (its HELLO/INFO) is the tools'."""
        try:
            for path, tool in self.tools:
                check_device(tool, info_dict(client.info), path)
        except InputError:
            self.refused = True
            raise

    def samples_on(self, client):
        """Switch the SAMPLE stream on (not persisted); INFO read again, so meta.json's
        device says it streams."""
        i = client.info
        if i.flags & C.CFG_STREAM_SAMPLES:
            return
        levels = (to_newtons(i.enter_threshold), to_newtons(i.exit_threshold))
        values = (i.rate_hz, *levels, i.debounce)
        flags = i.flags & C.CFG_WRITABLE & ~C.CFG_PERSIST
        client.configure(*values, flags | C.CFG_STREAM_SAMPLES)
        self.restore = (*values, flags)
        client.get_info()

    def put_back(self, client):
        """The board's configuration as it was before ``samples_on`` (if it is still there)."""
        if self.restore is not None and client is not None:
            with contextlib.suppress(BoardError):
                client.configure(*self.restore)

    def meta(self):
        """meta.json's "payload": each tool file and its values."""
        tools = [{"file": str(path), "tool": tool_doc(tool)} for path, tool in self.tools]
        return {"tools": tools, "samples_switched_on": self.restore is not None}


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
