"""The live 3D scene beside ``LiveServer``'s wrench topics, when a pose log is given.

``ScenePublisher.feed`` puts each batch of frames into a ``Worker``'s bounded queue
(``tactile.foxglove.topics``; full: the batch is dropped and counted) and returns.  The
worker's ``scene`` thread localises the readings
(``tactile.foxglove.live_scene``) and publishes ``/tactile/contacts`` (one entity of
arrows per contact, replaced as its readings arrive) and ``/tactile/tf`` (a sensor's pose
when it enters a pose-log window).  When a contact ends and at least
``MIN_PATCH_CONTACTS`` are localised, the contacts so far go to an ``ep2`` thread through a
one-slot mailbox: a request not yet started is replaced by the newer one (counted as
``stale``), so the fit never holds the recording or the scene back.  It fits the patch as
``tactile ep2 analyze`` does by default (``scene.fit_patch``) and publishes ``/tactile/patch``
(``tactile.foxglove.scene``).  A client that subscribes later is sent the scene so far
(``resend``: the SDK's callback queues it for the ``scene`` thread).

**Contacts localised as frames arrive**, through the robot's pose log, for a live view.

``LiveContacts.add(msgs, host_times, device)`` takes one batch of decoded frames with the
host stamps ``tactile.recording.timebase.RecordingClock.take`` gave them and returns a
``Batch``: the readings it localised (world points in m, object normals), the sensors whose
pose-log window changed (for a transform), and the contacts that ended.  The rule for
which CONTACT frames are readings is ``derive``'s (``tactile.localize.contact``) and the
localisation is ``posed_world_contacts``, so a run's contacts equal its contacts.csv when
the log is in the board's clock.  A host-clock log is joined by the running fit of the
arrivals here, by the final fit in contacts.csv: a reading at a window's edge may differ.
"""

import threading
import time
from dataclasses import dataclass, field

import numpy as np

from tactile.errors import InputError
from tactile.foxglove import scene
from tactile.foxglove.topics import CONTACTS_TOPIC, PATCH_TOPIC, TF_TOPIC, Worker
from tactile.localize.contact import Readings, contact_frames
from tactile.localize.posed import posed_world_contacts, sensor_poses, window_index
from tactile_protocol import constants as C

__all__ = ["Batch", "LiveContacts"]

QUEUE_BATCHES = 1024
MIN_PATCH_CONTACTS = 6  # a 2-jet's terms; EP2 refuses on its own where fewer do not fit
_RESEND = object()


class _Rows:
    """The contacts so far: points (m) and normals in arrays that double as they fill (a
    list turned into an array per batch would cost n^2 over a run), fingers in a list."""

    def __init__(self):
        self.n = 0
        self.points, self.normals, self.finger = np.empty((256, 3)), np.empty((256, 3)), []

    def add(self, points, normals, finger):
        """Append; the new rows' indices."""
        k = len(points)
        if self.n + k > len(self.points):
            size = max(2 * len(self.points), self.n + k)
            self.points = np.resize(self.points, (size, 3))
            self.normals = np.resize(self.normals, (size, 3))
        self.points[self.n : self.n + k] = points
        self.normals[self.n : self.n + k] = normals
        self.finger.extend(np.asarray(finger).tolist())
        self.n += k
        return range(self.n - k, self.n)

    def arrays(self):
        return self.points[: self.n], self.normals[: self.n]


class ScenePublisher:
    """Localise, publish contacts and transforms, fit patches; all off the caller's loop."""

    def __init__(self, topics, log, per_contact=None):
        self.topics = topics  # tactile.foxglove.topics.Topics: the live server's channels
        topics.declare(CONTACTS_TOPIC, PATCH_TOPIC, TF_TOPIC)
        self.live = LiveContacts(log, per_contact)
        self.rows = _Rows()
        self.entities = {}  # (sensor, contact id) -> [entity id, [row indices]]
        self.shown = {}  # entity id -> [row indices], every contact so far
        self.poses = {}  # sensor -> its latest (R, t)
        self.last_patch = None
        self.next_entity = 0
        self.stale = self.patches = self.ep2_failed = 0
        self.ep2_error = None
        self._mailbox = None
        self._wake = threading.Condition()
        self._closing = False
        self._ep2_thread = threading.Thread(target=self._ep2, name="foxglove-ep2", daemon=True)
        self._ep2_thread.start()
        self.worker = Worker("foxglove-scene", self._scene, QUEUE_BATCHES)

    def feed(self, msgs, host_times, device):
        self.worker.put((list(msgs), host_times, device))

    def resend(self, topic):
        """Publish the scene so far again (a client subscribed to ``topic``): the SDK's
        callback thread only queues the request."""
        if topic in (CONTACTS_TOPIC, PATCH_TOPIC, TF_TOPIC):
            self.worker.put((_RESEND, topic))

    def _scene(self, item):
        self._again(item[1]) if item[0] is _RESEND else self._take(*item)

    def _again(self, topic):
        ns = time.time_ns()
        if topic == CONTACTS_TOPIC and self.shown:
            pts, nrm = self.rows.arrays()
            for entity_id, rows in self.shown.items():
                update = scene.contacts_update(entity_id, pts[rows], nrm[rows], ns)
                self.topics.scene(CONTACTS_TOPIC, update, ns)
        elif topic == TF_TOPIC:
            for sensor, (R, t) in self.poses.items():
                self.topics.scene(TF_TOPIC, scene.sensor_transform(sensor, R, t, ns), ns)
        elif topic == PATCH_TOPIC and self.last_patch is not None:
            self.topics.scene(PATCH_TOPIC, self.last_patch, ns)

    def _take(self, msgs, host_times, device):
        b = self.live.add(msgs, host_times, device, time.time_ns())
        for sensor, R, t, ns in b.poses:
            self.poses[sensor] = (R, t)
            self.topics.scene(TF_TOPIC, scene.sensor_transform(sensor, R, t, ns), ns)
        touched = {}
        for row, key in zip(self.rows.add(b.points, b.normals, b.finger), b.keys):
            entry = self.entities.get(key)
            if entry is None:
                entry = self.entities[key] = [f"contact{self.next_entity}", []]
                self.shown[entry[0]] = entry[1]
                self.next_entity += 1
            entry[1].append(row)
            touched[entry[0]] = entry[1]
        pts, nrm = self.rows.arrays()
        for entity_id, rows in touched.items():
            update = scene.contacts_update(entity_id, pts[rows], nrm[rows], b.ns)
            self.topics.scene(CONTACTS_TOPIC, update, b.ns)
        for key in b.ended:
            self.entities.pop(key, None)  # the board may reuse the id: a new entity then
        if b.ended and len(pts) >= MIN_PATCH_CONTACTS:
            self.request(pts.copy(), nrm.copy(), np.asarray(self.rows.finger), b.ns)

    def request(self, points, normals, finger, ns):
        """Ask for a patch fit of these contacts; replaces a request not yet started."""
        with self._wake:
            self.stale += self._mailbox is not None
            self._mailbox = (points, normals, finger, ns)
            self._wake.notify()

    def _ep2(self):
        while True:
            with self._wake:
                while self._mailbox is None and not self._closing:
                    self._wake.wait()
                if self._mailbox is None:
                    return
                pts, nrm, finger, ns = self._mailbox
                self._mailbox = None
            try:
                record, mesh = scene.fit_patch(pts, nrm, finger)
                anchor = pts.mean(axis=0)
                update = scene.patch_update(record, mesh, anchor, len(pts), ns)
                self.topics.scene(PATCH_TOPIC, update, ns)
                self.last_patch = update
                self.patches += 1
            except Exception as exc:  # EP2 failing otherwise: say so, keep recording
                self.ep2_failed += 1
                self.ep2_error = self.ep2_error or f"EP2: {type(exc).__name__}: {exc}"

    def close(self, timeout_s=10.0):
        """Finish the queued batches and the pending fit (up to ``timeout_s`` each)."""
        self.worker.close(timeout_s)
        with self._wake:
            self._closing = True
            self._wake.notify()
        self._ep2_thread.join(timeout_s)

    def stats(self):
        w = self.worker
        return {
            "contacts": self.rows.n,
            "patches": self.patches,
            "stale_fits": self.stale,
            "dropped_batches": w.dropped,
            "localise_error": self.live.error,
            "failed": w.failed + self.ep2_failed,
            "error": w.error or self.ep2_error,
        }


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
