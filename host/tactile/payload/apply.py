"""The compensator where the readings are (a live stream, a run on the board, a recording),
and the sensor's orientation it needs at each reading.

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

**The sensor's orientation** at any reading's time, from a robot's log.

A robot log gives, per sensor, windows in which the sensor is held at a known pose
(``tactile.logs.read``: a generic log's quaternions, a SCARA log's joints).  A
reading inside a window has that window's orientation.  Between two windows of its sensor
the robot is moving and the log does not say how: the orientation is interpolated along
the shortest rotation from the end of one window to the start of the next, with a
(1 - cos)/2 profile in time (a move that starts and stops smoothly, as a robot's does and
the simulator's ``poses`` and ``sweep`` motions do).  Before the first window and after the
last, the nearest window's orientation holds.  ``at`` also says which readings are inside a
window (exact) and which are interpolated (as good as the robot's path is that arc).
"""

import contextlib
import time

import numpy as np
from scipy.spatial.transform import Rotation

from tactile.board.client import info_dict
from tactile.errors import BoardError, InputError
from tactile.localize.posed import sensor_poses
from tactile.logs.read import log_columns, read_pose_log, read_probe_log
from tactile.payload.compensator import Compensator
from tactile.payload.tool import Tool, check_device, read_tool, tool_doc
from tactile.recording import load as recording
from tactile_protocol import constants as C
from tactile_protocol.settings import to_newtons

__all__ = [
    "Following",
    "OnBoard",
    "compensate_recording",
    "load_recording",
    "ANY",
    "Orientations",
    "read_log",
]


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


ANY = -1  # the key of windows that hold for every sensor (a SCARA log has one sensor)


class Orientations:
    """Per sensor, windows [t_start, t_end] (us, the log's clock) and the sensor's
    orientation in each (``Rotation``, the sensor frame's axes in the world's)."""

    def __init__(self, windows, path=""):
        self.path = str(path)
        self.windows = {}
        for sensor, (t0, t1, rot) in windows.items():
            order = np.argsort(np.asarray(t0), kind="stable")
            self.windows[int(sensor)] = (
                np.asarray(t0, dtype=np.int64)[order],
                np.asarray(t1, dtype=np.int64)[order],
                rot[order],
            )

    @classmethod
    def of_log(cls, log):
        """From a pose log (``PoseLog``) or an EP1 probe log (``ProbeLog``) with orientations."""
        return cls.from_probe_log(log) if hasattr(log, "q_start") else cls.from_pose_log(log)

    @classmethod
    def from_pose_log(cls, log):
        """From a ``PoseLog``: a generic log's R per window and finger; a SCARA log's
        joints through eq. 62 (one sensor, every window)."""
        if log.kind == "scara":
            R, _ = sensor_poses(log, np.arange(len(log)))
            return cls({ANY: (log.t_start, log.t_end, Rotation.from_matrix(R))}, log.path)
        if log.quaternion is None:
            raise InputError(f"{log.path}: the log has no orientations (columns qw,qx,qy,qz)")
        out = {}
        for f in np.unique(log.finger):
            rows = np.flatnonzero(log.finger == f)
            R, _ = sensor_poses(log, rows)
            out[int(f)] = (log.t_start[rows], log.t_end[rows], Rotation.from_matrix(R))
        return cls(out, log.path)

    @classmethod
    def from_probe_log(cls, log):
        """From an EP1 ``ProbeLog`` with orientations: each probe's hold at its start and at
        its end (``half_width_us`` either side of the logged time), one sensor."""
        if log.q_start is None:
            raise InputError(
                f"{log.path}: the probe log has no orientations (columns qw,qx,qy,qz and"
                " qw_end,qx_end,qy_end,qz_end): the tool's weight cannot be removed"
            )
        half = round(log.half_width_us or 0)
        t = np.concatenate([log.t_start_us, log.t_end_us])
        q = np.concatenate([log.q_start, log.q_end])
        rot = Rotation.from_quat(np.roll(q, -1, axis=1))  # scipy: x, y, z, w
        return cls({ANY: (t - half, t + half, rot)}, log.path)

    def sensors(self):
        """The sensor indices the log has windows for (``ANY``: every sensor)."""
        return sorted(self.windows)

    def covers(self, sensor):
        """Whether the log says anything of ``sensor``'s orientation."""
        return int(sensor) in self.windows or ANY in self.windows

    def _of(self, sensor):
        got = self.windows.get(int(sensor), self.windows.get(ANY))
        if got is None:
            raise InputError(
                f"{self.path}: no window of sensor {int(sensor)} (the log has"
                f" {', '.join(str(s) for s in self.sensors())})"
            )
        return got

    def at(self, sensor, t_us):
        """(R (n, 3, 3), held (n,) bool) of ``sensor`` at times ``t_us`` (n,): a window's
        orientation inside it, interpolated between windows (module docstring)."""
        t0, t1, rot = self._of(sensor)
        t = np.asarray(t_us, dtype=np.int64).ravel()
        k = np.searchsorted(t0, t, side="right") - 1
        inside = (k >= 0) & (t <= t1[np.clip(k, 0, None)])
        k = np.clip(k, 0, len(t0) - 1)
        out = rot[k]
        moving = np.flatnonzero(~inside & (t > t1[k]) & (k + 1 < len(t0)))
        if moving.size:
            a, b = k[moving], k[moving] + 1
            span = np.maximum(t0[b] - t1[a], 1).astype(float)
            frac = (1.0 - np.cos(np.pi * np.clip((t[moving] - t1[a]) / span, 0.0, 1.0))) / 2
            step = (rot[a].inv() * rot[b]).as_rotvec()
            between = rot[a] * Rotation.from_rotvec(frac[:, None] * step)
            R = out.as_matrix()
            R[moving] = between.as_matrix()
            return R, inside
        return out.as_matrix().reshape(-1, 3, 3), inside

    def held_windows(self, sensor):
        """(t_start (k,), t_end (k,), R (k, 3, 3)) of ``sensor``'s windows, in time order."""
        t0, t1, rot = self._of(sensor)
        return t0, t1, rot.as_matrix().reshape(-1, 3, 3)


def read_log(path):
    """(the log, its ``Orientations``) of a robot log at ``path``: an EP1 probe log (with
    orientation columns) or a pose log; InputError when it gives no orientation."""
    log = read_probe_log(path) if "dtheta_x" in log_columns(path) else read_pose_log(path)
    return log, Orientations.of_log(log)
