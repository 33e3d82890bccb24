"""A Foxglove WebSocket server of a board's frames, as ``tactile live`` and ``record`` run.

``LiveServer`` starts a ``WebSocketSink`` (``tactile.foxglove.topics``: foxglove-sdk's server,
the ``foxglove`` extra, imported only here, only when asked) on a context of its own and
logs the topics of ``tactile.foxglove.topics``, the same as the MCAP export: per sensor the
wrench (ROS 2 WrenchStamped, CDR) and the contact state.

Bounded: ``feed`` only decimates and puts into a ``Worker``'s queue of ``QUEUE_FRAMES``; a
full queue drops the frame and counts it (``dropped``).  The worker's thread encodes and
logs to the SDK, which keeps ``BACKLOG`` messages per client and drops a slow client's
oldest (its own rule; it counts nothing the SDK shows).  So the caller's loop never waits
on a client.

With a robot's ``pose_log`` (a ``PoseLog``) the 3D scene is published too: contacts,
transforms and the EP2 patch (``tactile.foxglove.live_scene``, off this loop as well).

The SDK's own log lines (a client's bad message, a connection) go to the ``tactile.foxglove``
logger, escaped and at most ``tactile.output.text.LINES`` per ``INTERVAL_S``
(``tactile.foxglove.topics.sdk``): shown with ``tactile -v``, never raw, never without it.

Start-up: ``tactile live`` imports this module whether or not it serves, so what needs
NumPy (the scene, the arrivals' fit) is imported when first used.

Rate: ``rate_hz`` per sensor by the board's stamps (0: every frame); CONTACT frames that
begin or end a contact always pass.  Stamps: the host UTC the caller gives (``record``: the
board -> host fit as it stands), else this server's own fit of the arrivals
(``tactile.recording.timebase.RecordingClock``), as ns; for a board on simulated time
(``simulated``: the port's ``simulated_time``), and until the fit is a clock's, the host's
UTC as the frame is fed.
"""

import time

from tactile.board.client import info_dict
from tactile.foxglove.topics import Topics, WebSocketSink, Worker, contact_topic, sdk, wrench_topic
from tactile_protocol import constants as C
from tactile_protocol.settings import wrench_si

QUEUE_FRAMES = 4096  # frames between the caller's loop and the publishing thread
BACKLOG = 1024  # messages the SDK keeps per client before it drops the oldest
REFIT_S = 1.0
LINGER_S = 0.3
DEFAULT_RATE_HZ = 100.0


def require_foxglove():
    """(foxglove, its adopted log handler), or ``MissingExtra`` naming the extra."""
    return sdk("foxglove", "--foxglove")


class Decimator:
    """Which frames pass at ``rate_hz`` per sensor, by the board's us stamps (0: all)."""

    def __init__(self, rate_hz):
        self.period_us = round(1e6 / rate_hz) if rate_hz else 0
        self.last = {}

    def keep(self, m):
        if not self.period_us or (m.type_code == C.MSG_CONTACT and m.phase != C.PHASE_IN):
            self.last[m.sensor] = m.timestamp_us
            return True
        last = self.last.get(m.sensor)
        if last is not None and (m.timestamp_us - last) % C.TIMESTAMP_MODULO < self.period_us:
            return False
        self.last[m.sensor] = m.timestamp_us
        return True


class _Listener:
    """The SDK's callbacks: a client that subscribes to a scene topic gets the scene so far
    (its entities would otherwise appear only as they change)."""

    def __init__(self, server):
        self.server = server

    def on_subscribe(self, client, channel):
        if self.server.scene is not None:
            self.server.scene.resend(channel.topic)

    def on_unsubscribe(self, client, channel):
        """Nothing to do; the SDK calls it on every listener it is given."""


def sensor_topics(device):
    """The wrench and contact topics of every sensor ``device`` (``info_dict``) names, else of
    sensor 0.  Made before the server starts: foxglove-sdk advertises a channel made later
    to a connected client before it files the channel as that client's, so a client that
    subscribes at once can be refused ("unknown channel", docs/foxglove.md: limits); the
    channels a client finds at connection are filed before its messages are read."""
    n = len(device["cal_ids"]) if device and device.get("cal_ids") else 1
    return [topic(sensor) for sensor in range(n) for topic in (wrench_topic, contact_topic)]


class LiveServer:
    """The server on ``host``:``port`` (0: any free port; ``port`` says which)."""

    def __init__(
        self, host="127.0.0.1", port=8765, rate_hz=DEFAULT_RATE_HZ, device=None, pose_log=None,
        per_contact=None, topics=(), simulated=False,
    ):  # fmt: skip
        fox, self.sdk_log = require_foxglove()  # adopted before the SDK's first line
        self.device = device
        self.rate_hz = rate_hz
        self.decimator = Decimator(rate_hz)
        self.context = fox.Context()
        self.topics = Topics(fox, self.context)
        # before the server listens (see ``sensor_topics``): the caller's own topics too
        self.topics.declare(*sensor_topics(device), *topics)
        self.simulated = simulated  # the port's board runs on simulated time: no clock fit
        self.scene = None
        if pose_log is not None:
            from tactile.foxglove.live_scene import ScenePublisher  # NumPy, EP2: start-up

            self.scene = ScenePublisher(self.topics, pose_log, per_contact)
        listener = _Listener(self) if pose_log is not None else None
        self.sink = WebSocketSink(fox, self.context, host, port, BACKLOG, listener)
        self.host, self.port = host, self.sink.port
        self.fed = 0
        self.offered = self.other = 0  # every frame fed; ... not a reading (HELLO, STATUS)
        self._clock = None
        self._info = None
        self._fit_at = 0.0
        self.worker = Worker("foxglove", self._publish, QUEUE_FRAMES)

    @property
    def url(self):
        return self.sink.url

    def feed(self, msgs, host_times=None, arrivals=None):
        """Queue the SAMPLE/CONTACT frames of ``msgs`` that pass the rate.  ``host_times``:
        one (monotonic s, UTC s) or None per message (``RecordingClock.take``); else
        ``arrivals`` (monotonic s per message) are fitted here."""
        if host_times is None:
            host_times = self._stamp(msgs, arrivals)
        self.offered += len(msgs)
        for m, t in zip(msgs, host_times):
            if m.type_code not in (C.MSG_SAMPLE, C.MSG_CONTACT):
                self.other += 1
                continue
            if not self.decimator.keep(m):
                continue
            self.fed += 1
            ns = time.time_ns() if t is None else round(t[1] * 1e6) * 1000
            self.worker.put((m, ns))

    def follow(self, session, msgs, host_times):
        """``tactile.recording.session.Session``'s ``on_frames``: its board's INFO (thresholds,
        kept while it stays the same object) and its stamps."""
        info = session.client.info if session.client is not None else None
        if info is not None and info is not self._info:
            self._info, self.device = info, info_dict(info)
        self.feed(msgs, host_times)
        if self.scene is not None:
            self.scene.feed(msgs, host_times, self.device)

    def _stamp(self, msgs, arrivals):
        if arrivals is None or self.simulated:  # stamped as they are fed
            return [None] * len(msgs)
        if self._clock is None:
            from tactile.recording.timebase import RecordingClock  # NumPy: start-up

            self._clock = RecordingClock(0, time.time() - time.monotonic())
        out = self._clock.take(msgs, arrivals)
        if time.monotonic() - self._fit_at >= REFIT_S:
            self._fit_at = time.monotonic()
            self._clock.refit()
        return out

    def _publish(self, item):
        self._log(*item)

    def _log(self, m, ns):
        w = wrench_si(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz)
        is_contact = m.type_code == C.MSG_CONTACT
        phase, cid = (m.phase, m.contact_id) if is_contact else (None, -1)
        self.topics.frame(m.sensor, ns, w, m.seq, is_contact, phase, cid, m.flags, self.device)

    def close(self, timeout_s=2.0):
        """Publish what is queued (up to ``timeout_s``), stop the server; return ``stats``."""
        self.worker.close(timeout_s)
        if self.scene is not None:
            self.scene.close()
            time.sleep(LINGER_S)  # the SDK sends the last patch before the server stops
        self.topics.close()
        self.sink.close()
        self.sdk_log.flush()  # "... K lines suppressed" of the last interval
        return self.stats()

    def stats(self):
        w = self.worker
        return {
            "url": self.url,
            "rate_hz": self.rate_hz,
            "offered": self.offered,  # every frame the board sent
            "other": self.other,  # ... not a reading: HELLO, INFO, ACK, STATUS
            "decimated": self.offered - self.other - self.fed,  # readings left out by the rate
            "frames": self.fed,
            "published": w.done,
            "dropped": w.dropped,
            "failed": w.failed,
            "error": w.error,
            "scene": None if self.scene is None else self.scene.stats(),
        }
