"""The topics and schemas Foxglove sees, each declared once, for every sink: the live
WebSocket server (``tactile.foxglove.live``) and the MCAP file (``tactile.foxglove.export_mcap``).

- ``/tactile/sensorN/wrench``: ROS 2 ``geometry_msgs/msg/WrenchStamped`` (schema encoding
  ``ros2msg``, messages CDR), force in N and torque in N*m, ``header.frame_id``
  ``tactile_sensorN``.  Foxglove has no wrench schema of its own; its Plot panel reads
  ``.wrench.force.x`` and the ROS 2 tools read the recording as is.
- ``/tactile/sensorN/contact``: ``tactile/ContactState`` (JSON, described by a JSON
  Schema): the frame's contact state beside the gate's thresholds, units in the names.
- ``/tactile/contacts``, ``/tactile/patch``: ``foxglove.SceneUpdate``; ``/tactile/tf``:
  ``foxglove.FrameTransform`` (protobuf, the SDK's own schemas; built by
  ``tactile.foxglove.scene``): the localised contacts as arrows along their normals, the
  latest EP2 patch, and each sensor's pose from the robot's pose log.

``Topics`` makes each topic's channel in a foxglove-sdk context the first time it is logged
(or when ``declare``d), from the declarations here; whichever sinks listen to that context
(``tactile.foxglove.topics``) get the same messages.  ``wrench_cdr`` encodes a WrenchStamped:
its layout is fixed (XCDR1, little-endian), and the one library encoder there is
(``mcap_ros2``'s) is private; the tests decode it with ``mcap_ros2``'s public decoder.

**Where the topics go** (the sinks), and the thread that keeps the live view off the caller's loop.

A sink takes every message ``Topics`` logs in its foxglove-sdk context; it is the SDK's own,
so a topic is declared once and logged once, whichever sinks listen:

- ``WebSocketSink``: the SDK's WebSocket server (``tactile live`` and ``record
  --foxglove``); it keeps ``backlog`` messages per client and drops a slow client's oldest;
- ``McapSink``: the SDK's MCAP writer into a binary file the caller opened (``tactile
  export``'s temporary, ``tactile.files.writing``), with MCAP's ``ros2`` profile.  A write the
  file refuses (a full disk) stops the export, and ``close`` raises it as the ``OSError``
  it was (the SDK's own error names no errno).

Both are context managers (``close`` on the way out).  ``sdk`` imports foxglove-sdk for an
extra and hands its log lines to ``tactile.output.text.adopt`` (escaped, rate-limited, shown
with ``tactile -v``).  ``Worker`` is the one bounded queue, stop marker and thread of the
live view: ``put`` never waits, a full queue drops the item and counts it.
"""

import contextlib
import json
import queue
import struct
import threading

from tactile.errors import InputError, need
from tactile.output.text import adopt
from tactile_protocol import constants as C

__all__ = ["McapSink", "Sink", "WebSocketSink", "Worker", "sdk"]

SEP = "=" * 80 + "\n"
TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
VECTOR = "float64 x\nfloat64 y\nfloat64 z\n"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
WRENCH_STAMPED_DEF = SEP.join(
    [
        "std_msgs/Header header\ngeometry_msgs/Wrench wrench\n",
        HEADER,
        TIME,
        "MSG: geometry_msgs/Wrench\ngeometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque\n",
        "MSG: geometry_msgs/Vector3\n" + VECTOR,
    ]
)
CDR_LE = b"\x00\x01\x00\x00"  # the encapsulation header: plain CDR, little-endian
CONTACTS_TOPIC = "/tactile/contacts"  # foxglove.SceneUpdate: arrows, m
PATCH_TOPIC = "/tactile/patch"  # foxglove.SceneUpdate: mesh and text, m
TF_TOPIC = "/tactile/tf"  # foxglove.FrameTransform: world -> tactile_sensorN, m
NEXT_TOUCH_TOPIC = "/tactile/next_touch"  # foxglove.SceneUpdate: tactile explore's next, m
SCENE_TOPICS = (CONTACTS_TOPIC, PATCH_TOPIC, TF_TOPIC)
SCENE_SCHEMAS = {
    CONTACTS_TOPIC: "SceneUpdate",
    PATCH_TOPIC: "SceneUpdate",
    TF_TOPIC: "FrameTransform",
    NEXT_TOUCH_TOPIC: "SceneUpdate",
}
WORLD_FRAME = "world"

CONTACT_STATE = "tactile/ContactState"
_NUMBER_OR_NULL = {"type": ["number", "null"]}
CONTACT_STATE_SCHEMA = {
    "title": CONTACT_STATE,
    "description": "A SAMPLE or CONTACT frame's contact state and the board's contact gate",
    "type": "object",
    "properties": {
        "timestamp": {
            "type": "object",
            "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
        },
        "sensor": {"type": "integer"},
        "seq": {"type": "integer", "description": "the frame's 16-bit sequence number"},
        "frame": {"type": "string", "enum": ["sample", "contact"]},
        "phase": {"type": ["string", "null"], "enum": ["begin", "in", "end", None]},
        "contact_id": {"type": "integer", "description": "-1 on a SAMPLE frame"},
        "in_contact": {"type": "boolean"},
        "saturated_mask": {"type": "integer", "description": "bit i: gauge channel i"},
        "enter_threshold_N": _NUMBER_OR_NULL,
        "exit_threshold_N": _NUMBER_OR_NULL,
        "debounce_readings": {"type": ["integer", "null"]},
        "gate": {"type": ["string", "null"], "enum": ["xy", "3d", None]},
    },
}
PHASES = {C.PHASE_BEGIN: "begin", C.PHASE_IN: "in", C.PHASE_END: "end"}


class Topics:
    """The channels of one foxglove-sdk ``context`` (``fox``: the ``foxglove`` module), each
    made from the declarations above when first logged; ``close`` unadvertises them."""

    def __init__(self, fox, context):
        self.fox, self.context = fox, context
        self.channels = {}

    def frame(self, sensor, ns, wrench, seq, is_contact, phase, contact_id, flags, device):
        """A SAMPLE or CONTACT frame's two messages at ``ns``: its wrench (N, N*m) and its
        contact state (``contact_message``)."""
        self._channel(wrench_topic(sensor)).log(wrench_cdr(sensor, ns, wrench), log_time=ns)
        c = contact_message(sensor, ns, seq, is_contact, phase, contact_id, flags, device)
        data = json.dumps(c, separators=(",", ":")).encode()
        self._channel(contact_topic(sensor)).log(data, log_time=ns)

    def declare(self, *topics):
        """Make these topics' channels now: a server advertises them before their first
        message."""
        for topic in topics:
            self._channel(topic)

    def scene(self, topic, message, ns):
        """A ``foxglove.messages`` message (``tactile.foxglove.scene``) on a scene topic."""
        self._channel(topic).log(message, log_time=ns)

    def close(self):
        for channel in self.channels.values():
            channel.close()

    def _channel(self, topic):
        channel = self.channels.get(topic)
        if channel is None:
            channel = self.channels[topic] = self._declare(topic)
        return channel

    def _declare(self, topic):
        fox, context = self.fox, self.context
        if topic in SCENE_SCHEMAS:
            kind = getattr(fox.channels, f"{SCENE_SCHEMAS[topic]}Channel")
            return kind(topic, context=context)
        if topic.endswith("/wrench"):
            schema = fox.Schema(
                name=WRENCH_STAMPED, encoding="ros2msg", data=WRENCH_STAMPED_DEF.encode()
            )
            return fox.Channel(topic, schema=schema, message_encoding="cdr", context=context)
        schema = fox.Schema(
            name=CONTACT_STATE,
            encoding="jsonschema",
            data=json.dumps(CONTACT_STATE_SCHEMA).encode(),
        )
        return fox.Channel(topic, schema=schema, message_encoding="json", context=context)


def wrench_topic(sensor):
    return f"/tactile/sensor{sensor}/wrench"


def contact_topic(sensor):
    return f"/tactile/sensor{sensor}/contact"


def sensor_frame(sensor):
    return f"tactile_sensor{sensor}"


def wrench_cdr(sensor, ns, wrench):
    """A WrenchStamped, CDR-encoded: stamp ``ns`` (Unix or board-clock ns), frame
    ``tactile_sensorN``, ``wrench`` = (fx, fy, fz) in N then (tx, ty, tz) in N*m."""
    sec, nsec = divmod(int(ns), 1_000_000_000)
    frame = sensor_frame(sensor).encode() + b"\x00"
    head = struct.pack("<iII", sec, nsec, len(frame)) + frame
    pad = bytes(-len(head) % 8)  # the float64s align to 8 from the encapsulation's end
    return CDR_LE + head + pad + struct.pack("<6d", *map(float, wrench[:6]))


def contact_message(sensor, ns, seq, is_contact, phase, contact_id, flags, device):
    """A ContactState dict.  ``phase``/``contact_id``: the CONTACT frame's (ignored on a
    SAMPLE); ``device``: HELLO/INFO as ``tactile.board.client.info_dict`` gives it (or
    None: the thresholds are then null)."""
    device = device or {}
    if is_contact:
        in_contact = phase != C.PHASE_END
    else:
        in_contact, phase, contact_id = bool(flags & C.FLAG_IN_CONTACT), None, -1
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return {
        "timestamp": {"sec": sec, "nsec": nsec},
        "sensor": int(sensor),
        "seq": int(seq),
        "frame": "contact" if is_contact else "sample",
        "phase": PHASES.get(phase) if is_contact else None,
        "contact_id": int(contact_id),
        "in_contact": bool(in_contact),
        "saturated_mask": int(flags) & C.FLAG_SAT_MASK,
        "enter_threshold_N": device.get("enter_threshold_N"),
        "exit_threshold_N": device.get("exit_threshold_N"),
        "debounce_readings": device.get("debounce"),
        "gate": device.get("gate"),
    }


SDK_LOGGER, LOGGER = "foxglove", "tactile.foxglove"  # the SDK's loggers, and where they go
_STOP = object()


def sdk(extra, purpose, *modules):
    """The ``foxglove`` module (and ``modules``), or ``MissingExtra`` naming ``extra``; the
    SDK's loggers adopted before its first line.  Returns (modules..., the ``Adopted``
    handler)."""
    found = need(extra, purpose, "foxglove", *modules)
    return (*found, adopt(SDK_LOGGER, LOGGER))


class Sink:
    """A sink of a foxglove-sdk context: it gets what the context's channels log until
    ``close``."""

    def close(self):
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if kind is None:
            self.close()
            return
        with contextlib.suppress(Exception):  # the error on its way out is the one to see
            self.close()


class WebSocketSink(Sink):
    """The SDK's WebSocket server on ``host``:``port`` (0: any free port; ``port`` says
    which); ``listener``: the SDK's server callbacks, or None."""

    def __init__(self, fox, context, host, port, backlog, listener=None):
        try:
            self.server = fox.start_server(
                name="tactile",
                host=host,
                port=port,
                context=context,
                message_backlog_size=backlog,
                server_listener=listener,
            )
        except Exception as exc:  # the SDK's bind error (a RuntimeError, or its own class)
            raise InputError(f"--foxglove: cannot serve on {host}:{port} ({exc})") from None
        self.host, self.port = host, self.server.port

    @property
    def url(self):
        return f"ws://{self.host}:{self.port}"

    def close(self):
        self.server.stop()


class _Watched:
    """A binary file whose first failed call (a write, or the flush or seek that writes
    what is buffered) is kept, for ``McapSink``."""

    def __init__(self, fh):
        self.fh, self.error = fh, None

    def _call(self, name, *args):
        try:
            return getattr(self.fh, name)(*args)
        except OSError as exc:
            self.error = self.error or exc
            raise

    def write(self, data):
        return self._call("write", data)

    def seek(self, offset, whence=0):
        return self._call("seek", offset, whence)

    def tell(self):
        return self._call("tell")

    def flush(self):
        return self._call("flush")


class McapSink(Sink):
    """The SDK's MCAP writer into ``fh`` (open for binary writing, seekable)."""

    def __init__(self, fox, context, fh):
        self.file = _Watched(fh)
        options = fox.mcap.MCAPWriteOptions(profile="ros2")
        self.writer = fox.open_mcap(self.file, context=context, writer_options=options)

    @property
    def failed(self):
        """Whether a write failed: nothing more reaches the file."""
        return self.file.error is not None

    def metadata(self, name, values):
        """A metadata record ``name`` of string ``values``."""
        self._sdk(self.writer.write_metadata, name, values)

    def close(self):
        """Finish the file (summary, footer); a failed write is raised as it was."""
        self._sdk(self.writer.close)
        if self.file.error is not None:
            raise self.file.error

    def _sdk(self, call, *args):
        try:
            call(*args)
        except RuntimeError:  # the SDK's FoxgloveError: the file's own error, if it had one
            if self.file.error is None:
                raise
            raise self.file.error from None


class Worker:
    """A daemon thread that hands each item ``put`` to ``handle``, in order, until
    ``close``.  ``done``, ``dropped`` (the queue of ``size`` was full), ``failed`` (``handle``
    raised; ``error`` is the first such)."""

    def __init__(self, name, handle, size):
        self.handle = handle
        self.queue = queue.Queue(size)
        self.done = self.dropped = self.failed = 0
        self.error = None
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.thread.start()

    def put(self, item):
        """Queue ``item`` without waiting; False (and counted) when the queue is full."""
        try:
            self.queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            return False
        return True

    def close(self, timeout_s):
        """Handle what is queued, then stop (up to ``timeout_s`` to queue the stop and as
        long again for the thread)."""
        try:
            self.queue.put(_STOP, timeout=timeout_s)
        except queue.Full:
            pass
        self.thread.join(timeout_s)

    def _run(self):
        while True:
            item = self.queue.get()
            if item is _STOP:
                return
            try:
                self.handle(item)
                self.done += 1
            except Exception as exc:  # one bad item must not end the live view
                self.failed += 1
                self.error = self.error or f"{type(exc).__name__}: {exc}"
