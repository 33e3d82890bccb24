"""A Foxglove WebSocket server of a board's frames, as ``tactile live`` and ``record`` run.

``LiveServer`` starts ``foxglove-sdk``'s server (the ``foxglove`` extra, imported only
here, only when asked) in a context of its own and publishes the topics of
``tactile.recording.topics``, the same as the MCAP export: per sensor the wrench (ROS 2
WrenchStamped, CDR by ``mcap_ros2``'s encoder, as in the export) and the contact state.

Bounded: ``feed`` only decimates and puts into a queue of ``QUEUE_FRAMES``; a full queue
drops the frame and counts it (``dropped``).  A thread encodes and logs to the SDK, which
keeps ``BACKLOG`` messages per client and drops a slow client's oldest (its own rule; it
counts nothing the SDK shows).  So the caller's loop never waits on a client.

With a robot's ``pose_log`` (a ``PoseLog``) the 3D scene is published too: contacts,
transforms and the EP2 patch (``tactile.output.foxglove_scene``, off this loop as well).

The SDK's own log lines (a client's bad message, a connection) go to the ``tactile.foxglove``
logger, escaped and at most ``tactile.output.logs.LINES`` per ``INTERVAL_S``
(``tactile.output.logs.adopt``): shown with ``tactile -v``, never raw, never without it.

Rate: ``rate_hz`` per sensor by the board's stamps (0: every frame); CONTACT frames that
begin or end a contact always pass.  Stamps: the host UTC the caller gives (``record``: the
board -> host fit as it stands), else this server's own fit of the arrivals
(``tactile.recording.timebase.RecordingClock``), as ns.
"""

import json
import queue
import threading
import time

from tactile.extras import need
from tactile.output import logs
from tactile.recording.topics import (
    CONTACT_STATE,
    CONTACT_STATE_SCHEMA,
    WRENCH_STAMPED,
    WRENCH_STAMPED_DEF,
    contact_message,
    contact_topic,
    wrench_message,
    wrench_topic,
)
from tactile_protocol import constants as C

QUEUE_FRAMES = 4096  # frames between the caller's loop and the publishing thread
BACKLOG = 1024  # messages the SDK keeps per client before it drops the oldest
REFIT_S = 1.0
LINGER_S = 0.3
DEFAULT_RATE_HZ = 100.0
SDK_LOGGER, LOGGER = "foxglove", "tactile.foxglove"  # the SDK's loggers, and where they go
_STOP = object()


def require_foxglove():
    """(foxglove, mcap_ros2's encoder maker), or ``MissingExtra`` naming the extra."""
    fox, dyn = need("foxglove", "--foxglove", "foxglove", "mcap_ros2._dynamic")
    return fox, dyn.serialize_dynamic


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


class LiveServer:
    """The server on ``host``:``port`` (0: any free port; ``port`` says which)."""

    def __init__(
        self, host="127.0.0.1", port=8765, rate_hz=DEFAULT_RATE_HZ, device=None, pose_log=None,
        per_contact=None,
    ):  # fmt: skip
        fox, serialize = require_foxglove()
        self.sdk_log = logs.adopt(SDK_LOGGER, LOGGER)  # before the SDK's first line
        self._fox = fox
        self.encode = serialize(WRENCH_STAMPED, WRENCH_STAMPED_DEF)[WRENCH_STAMPED]
        self.device = device
        self.rate_hz = rate_hz
        self.decimator = Decimator(rate_hz)
        self.context = fox.Context()
        self.scene = None
        try:
            self.server = fox.start_server(
                name="tactile",
                host=host,
                port=port,
                context=self.context,
                message_backlog_size=BACKLOG,
                server_listener=_Listener(self) if pose_log is not None else None,
            )
        except Exception as exc:  # the SDK's bind error (a RuntimeError, or its own class)
            from tactile.errors import InputError

            raise InputError(f"--foxglove: cannot serve on {host}:{port} ({exc})") from None
        self.host, self.port = host, self.server.port
        self.channels = {}
        self.queue = queue.Queue(QUEUE_FRAMES)
        self.fed = self.published = self.dropped = self.failed = 0
        self.error = None
        self._clock = None
        self._info = None
        self._fit_at = 0.0
        self._thread = threading.Thread(target=self._publish, name="foxglove", daemon=True)
        self._thread.start()
        if pose_log is not None:
            from tactile.output.foxglove_scene import ScenePublisher

            self.scene = ScenePublisher(fox, self.context, pose_log, per_contact)

    @property
    def url(self):
        return f"ws://{self.host}:{self.port}"

    def feed(self, msgs, host_times=None, arrivals=None):
        """Queue the SAMPLE/CONTACT frames of ``msgs`` that pass the rate.  ``host_times``:
        one (monotonic s, UTC s) or None per message (``RecordingClock.take``); else
        ``arrivals`` (monotonic s per message) are fitted here."""
        if host_times is None:
            host_times = self._stamp(msgs, arrivals)
        for m, t in zip(msgs, host_times):
            if m.type_code not in (C.MSG_SAMPLE, C.MSG_CONTACT) or not self.decimator.keep(m):
                continue
            self.fed += 1
            ns = time.time_ns() if t is None else round(t[1] * 1e6) * 1000
            try:
                self.queue.put_nowait((m, ns))
            except queue.Full:
                self.dropped += 1

    def follow(self, session, msgs, host_times):
        """``tactile.recording.session.Session``'s ``on_frames``: its board's INFO (thresholds,
        kept while it stays the same object) and its stamps."""
        info = session.client.info if session.client is not None else None
        if info is not None and info is not self._info:
            from tactile.board.client import info_dict

            self._info, self.device = info, info_dict(info)
        self.feed(msgs, host_times)
        if self.scene is not None:
            self.scene.feed(msgs, host_times, self.device)

    def _stamp(self, msgs, arrivals):
        if arrivals is None:
            return [None] * len(msgs)
        if self._clock is None:
            from tactile.recording.timebase import RecordingClock

            self._clock = RecordingClock(0, time.time() - time.monotonic())
        out = self._clock.take(msgs, arrivals)
        if time.monotonic() - self._fit_at >= REFIT_S:
            self._fit_at = time.monotonic()
            self._clock.refit()
        return out

    def _channels(self, sensor):
        pair = self.channels.get(sensor)
        if pair is None:
            fox = self._fox
            ros = fox.Schema(
                name=WRENCH_STAMPED, encoding="ros2msg", data=WRENCH_STAMPED_DEF.encode()
            )
            state = fox.Schema(
                name=CONTACT_STATE,
                encoding="jsonschema",
                data=json.dumps(CONTACT_STATE_SCHEMA).encode(),
            )
            pair = (
                fox.Channel(
                    wrench_topic(sensor), schema=ros, message_encoding="cdr", context=self.context
                ),
                fox.Channel(
                    contact_topic(sensor),
                    schema=state,
                    message_encoding="json",
                    context=self.context,
                ),
            )
            self.channels[sensor] = pair
        return pair

    def _publish(self):
        while True:
            item = self.queue.get()
            if item is _STOP:
                return
            try:
                self._log(*item)
                self.published += 1
            except Exception as exc:  # one bad frame must not end the live view
                self.failed += 1
                self.error = self.error or f"{type(exc).__name__}: {exc}"

    def _log(self, m, ns):
        from tactile.board.settings import wrench_si

        wrench, state = self._channels(m.sensor)
        w = wrench_si(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz)
        wrench.log(self.encode(wrench_message(m.sensor, ns, w)), log_time=ns)
        is_contact = m.type_code == C.MSG_CONTACT
        phase, cid = (m.phase, m.contact_id) if is_contact else (None, -1)
        c = contact_message(m.sensor, ns, m.seq, is_contact, phase, cid, m.flags, self.device)
        state.log(json.dumps(c, separators=(",", ":")).encode(), log_time=ns)

    def close(self, timeout_s=2.0):
        """Publish what is queued (up to ``timeout_s``), stop the server; return ``stats``."""
        try:
            self.queue.put(_STOP, timeout=timeout_s)
        except queue.Full:
            pass
        self._thread.join(timeout_s)
        if self.scene is not None:
            self.scene.close()
            time.sleep(LINGER_S)  # the SDK sends the last patch before the server stops
        for pair in self.channels.values():
            for ch in pair:
                ch.close()
        self.server.stop()
        self.sdk_log.flush()  # "... K lines suppressed" of the last interval
        return self.stats()

    def stats(self):
        return {
            "url": self.url,
            "rate_hz": self.rate_hz,
            "frames": self.fed,
            "published": self.published,
            "dropped": self.dropped,
            "failed": self.failed,
            "error": self.error,
            "scene": None if self.scene is None else self.scene.stats(),
        }
