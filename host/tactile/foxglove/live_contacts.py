"""Contacts localised as frames arrive, through the robot's pose log, for a live view.

``LiveContacts.add(msgs, host_times, device)`` takes one batch of decoded frames with the
host stamps ``tactile.recording.timebase.RecordingClock.take`` gave them and returns a
``Batch``: the readings it localised (world points in m, object normals), the sensors whose
pose-log window changed (for a transform), and the contacts that ended.  The rule for
which CONTACT frames are readings is ``derive``'s (``tactile.localize.contact``) and the
localisation is ``posed_world_contacts``, so a run's contacts equal its contacts.csv when
the log is in the board's clock.  A host-clock log is joined by the running fit of the
arrivals here, by the final fit in contacts.csv: a reading at a window's edge may differ.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.errors import InputError
from tactile.localize.contact import Readings, contact_frames
from tactile.localize.posed import posed_world_contacts, sensor_poses, window_index
from tactile_protocol import constants as C

__all__ = ["Batch", "LiveContacts"]


@dataclass
class Batch:
    """What one batch added: ``points`` (k, 3) m, ``normals`` (k, 3), ``finger`` (k,),
    ``keys`` (sensor, contact id) per reading; ``poses`` [(sensor, R (3, 3), t (3,) m, ns)]
    of windows entered; ``ended`` [(sensor, contact id)]; ``ns`` the batch's last stamp."""

    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    finger: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    keys: list = field(default_factory=list)
    poses: list = field(default_factory=list)
    ended: list = field(default_factory=list)
    ns: int = 0


def stamp_ns(t, fallback_ns):
    """A frame's host UTC in ns (``host_times`` entry: (monotonic s, UTC s)), else fallback."""
    return fallback_ns if t is None else round(t[1] * 1e6) * 1000


class LiveContacts:
    """Localises the readings of successive batches through ``log`` (a ``PoseLog``)."""

    def __init__(self, log, per_contact=None):
        self.log, self.per_contact = log, per_contact
        self.rule = None
        self.threshold = 0.0
        self.window = {}  # sensor -> the pose-log row last entered
        self.error = None  # why localising stopped (a log it cannot use), once

    def _start(self, device):
        device = device or {}
        self.threshold = float(device.get("enter_threshold_N", 0.0))
        gate = device.get("gate", "xy")
        self.rule = Readings.for_log(self.log.kind, self.per_contact, self.threshold, gate)

    def _times_us(self, msgs, host_times):
        """Each frame's time in the log's clock (us); -1 where it has none."""
        clock = self.log.clock
        if clock == "board":
            return np.array([m.timestamp_us for m in msgs], dtype=np.int64)
        k = 1 if clock == "utc" else 0
        return np.array(
            [-1 if t is None else round(t[k] * 1e6) for t in host_times], dtype=np.int64
        )

    def add(self, msgs, host_times, device, now_ns):
        """The ``Batch`` of the SAMPLE and CONTACT frames of ``msgs`` (``now_ns``: the stamp
        of frames without a host time)."""
        out = Batch()
        frames = (C.MSG_SAMPLE, C.MSG_CONTACT)
        keep = [i for i, m in enumerate(msgs) if m.type_code in frames]
        if not keep or self.error is not None:
            return out
        if host_times is not None and len(keep) < len(msgs):
            host_times = [host_times[i] for i in keep]
        msgs = [msgs[i] for i in keep]
        if self.rule is None:
            self._start(device)
        host_times = host_times if host_times is not None else [None] * len(msgs)
        stamps = [stamp_ns(t, now_ns) for t in host_times]
        out.ns = stamps[-1]
        times = self._times_us(msgs, host_times)
        sensors = np.array([m.sensor for m in msgs], dtype=int)
        out.poses = self._entered(window_index(self.log, times, sensors), sensors, stamps)
        out.ended = [
            (m.sensor, m.contact_id)
            for m in msgs
            if m.type_code == C.MSG_CONTACT and m.phase == C.PHASE_END
        ]
        t, sensor, wrench, cid = contact_frames(msgs, times=times, rule=self.rule)
        if not len(t):
            return out
        try:
            found = posed_world_contacts(self.log, t, sensor, wrench, self.threshold)
        except (InputError, ValueError) as exc:
            self.error = str(exc)
            return out
        kept = found.report.kept
        out.points, out.normals, out.finger = found.points, found.normals, found.finger
        out.keys = list(zip(sensor[kept].tolist(), cid[kept].tolist()))
        return out

    def _entered(self, rows, sensors, stamps):
        found = entered(rows, sensors, self.window)
        if not found:
            return []
        R, t = sensor_poses(self.log, [row for _, _, row in found])
        return [(s, R[k], t[k], stamps[i]) for k, (i, s, _) in enumerate(found)]


def entered(rows, sensors, window):
    """[(frame index, sensor, log row)] of the frames where a sensor enters a window other
    than ``window``'s (sensor -> row, updated); ``rows`` from ``window_index`` (-1: none)."""
    out = []
    for i in np.flatnonzero(np.asarray(rows) >= 0):
        s, row = int(sensors[i]), int(rows[i])
        if window.get(s) != row:
            window[s] = row
            out.append((int(i), s, row))
    return out
