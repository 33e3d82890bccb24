"""A recording as an MCAP file of ROS 2 messages, for Foxglove and the ROS 2 tools.

- One topic per sensor, ``/tactile/sensorN/wrench``: a ``geometry_msgs/msg/WrenchStamped``
  per SAMPLE or CONTACT frame, force in N and torque in N*m (ROS's REP 103 units),
  ``header.frame_id`` ``tactile_sensorN``; beside it ``/tactile/sensorN/contact``, the
  frame's contact state and the gate's thresholds (JSON, ``tactile.recording.topics``).  The live
  server (``tactile.output.foxglove_live``) publishes the same topics and schemas.
- When the run has a contacts.csv, the live view's scene (``tactile.recording.scene``, the
  same ``foxglove.SceneUpdate`` schema, protobuf; needs the ``foxglove`` extra):
  ``/tactile/contacts``, one entity of arrows in frame ``world`` from every contact point
  (m) along its normal, and ``/tactile/patch``, the EP2 patch of all the contacts (as
  ``tactile ep2 analyze`` fits it) as a mesh coloured by S with its label and interval.
  contacts.csv carries no times, so both are stamped at the recording's first frame and a
  player shows them throughout.  With the robot's pose log, ``/tactile/tf``: a
  ``foxglove.FrameTransform`` world -> tactile_sensorN per pose-log window, stamped at the
  first frame of that sensor inside it.
- Stamps (``header.stamp`` and each message's log time): the host's UTC (Unix time, as ROS
  stamps) when every row has one (``tactile.recording.load``), else the board's clock
  (seconds since its segment's first frame's epoch: its boot).  The metadata record
  ``tactile`` says which, and why, with the units, topics and source.

The ``mcap``, ``mcap-ros2-support`` and ``foxglove-sdk`` packages are the ``export`` extra,
imported only here.
"""

import json
import pathlib

import numpy as np

from tactile import __version__
from tactile.extras import need
from tactile.files.atomic import atomic_write
from tactile.recording.topics import (
    CONTACT_STATE,
    CONTACT_STATE_SCHEMA,
    CONTACTS_TOPIC,
    PATCH_TOPIC,
    TF_TOPIC,
    WRENCH_STAMPED,
    WRENCH_STAMPED_DEF,
    contact_message,
    contact_topic,
    sensor_frame,
    wrench_message,
    wrench_topic,
)

__all__ = ["require_mcap", "stamps_ns", "write_mcap"]


def require_mcap():
    """The ROS 2 MCAP ``Writer`` class, or ``MissingExtra`` (the ``export`` extra: mcap,
    mcap-ros2-support, and foxglove-sdk for the scene's schemas)."""
    return need("export", "MCAP export", "mcap_ros2.writer", "foxglove.messages")[0].Writer


def stamps_ns(rec):
    """(int64 ns per row, "host UTC" or "board clock", a sentence saying which and why)."""
    if rec.host_utc_s is not None and np.isfinite(rec.host_utc_s).all():
        ns = np.round(rec.host_utc_s * 1e6).astype(np.int64) * 1000  # frames.csv: to the us
        return ns, "host UTC", f"host UTC, Unix time (from {rec.host_time_source})"
    ns = np.round(rec.board_time_s * 1e6).astype(np.int64) * 1000
    why = rec.host_time_why or "the recording has no host time"
    return ns, "board clock", f"board clock, s since its boot, not host time: {why}"


def write_mcap(rec, path, pose_log=None):
    """Write ``rec`` (a ``RecordingData``) to the MCAP file ``path``, replacing it whole
    (``tactile.files.atomic``); ``pose_log`` (a ``PoseLog``) adds the sensors'
    transforms.  Returns a summary dict (topics and message counts, the stamps' clock and
    why, the patch's record)."""
    Writer = require_mcap()
    path = pathlib.Path(path)
    stamps, clock, clock_why = stamps_ns(rec)
    topics = {wrench_topic(s): int(np.sum(rec.sensor == s)) for s in rec.sensors}
    topics.update({contact_topic(s): topics[wrench_topic(s)] for s in rec.sensors})
    scene_msgs = _scene(rec, stamps, pose_log)
    for topic, msgs in scene_msgs.items():
        topics[topic] = len(msgs) if topic != CONTACTS_TOPIC else len(rec.contacts.points_m)
    with atomic_write(path) as fh:  # a disk error: exit 5; not a file there: exit 2
        writer = Writer(fh)
        _write(writer, rec, stamps, clock_why, topics)
        _write_scene(writer._writer, scene_msgs)
        writer.finish()
    patch = scene_msgs.get(PATCH_TOPIC)
    return {
        "path": str(path),
        "clock": clock,
        "why": clock_why,
        "topics": topics,
        "patch": patch[0][2] if patch else None,
    }


def _scene(rec, stamps, pose_log):
    """{topic: [(ns, message, record or None)]} of the scene topics the run has."""
    from tactile.recording import scene

    out = {}
    if rec.contacts is not None and len(rec.contacts.points_m) and len(stamps):
        c, first = rec.contacts, int(stamps.min())
        out[CONTACTS_TOPIC] = [
            (first, scene.contacts_update("contacts", c.points_m, c.normals, first), None)
        ]
        rows = np.ones(len(c.points_m), bool)
        if c.patch is not None:  # several patches: the last one, as the live view ends
            rows = np.array([p == c.patch[-1] for p in c.patch])
        finger = None if c.finger is None else [f for f, r in zip(c.finger, rows) if r]
        pts, nrm = c.points_m[rows], c.normals[rows]
        record, mesh = scene.fit_patch(pts, nrm, finger)
        update = scene.patch_update(record, mesh, pts.mean(axis=0), len(pts), first)
        out[PATCH_TOPIC] = [(first, update, record)]
    if pose_log is not None and len(stamps):
        out[TF_TOPIC] = _transforms(rec, stamps, pose_log)
    return out


def _transforms(rec, stamps, log):
    from tactile.localize.posed import window_index
    from tactile.recording import scene
    from tactile.recording.live_contacts import entered, sensor_pose

    host = {"utc": rec.host_utc_s, "monotonic": rec.host_monotonic_s}.get(log.clock)
    if log.clock == "board":
        times = rec.board_us.astype(np.int64)
    elif host is not None:
        times = np.where(np.isfinite(host), np.round(np.nan_to_num(host) * 1e6), -1)
    else:
        return []
    rows = window_index(log, times.astype(np.int64), rec.sensor)
    out = []
    for i, s, row in entered(rows, rec.sensor, {}):
        ns = int(stamps[i])
        out.append((ns, scene.sensor_transform(s, *sensor_pose(log, row), ns), None))
    return out


def _write_scene(raw, scene_msgs):
    """The scene topics on ``raw`` (mcap's own Writer), with the SDK's protobuf schemas."""
    from tactile.recording import scene

    kinds = {CONTACTS_TOPIC: "SceneUpdate", PATCH_TOPIC: "SceneUpdate", TF_TOPIC: "FrameTransform"}
    schemas = {}
    for topic, msgs in scene_msgs.items():
        kind = kinds[topic]
        if kind not in schemas:
            schemas[kind] = raw.register_schema(*scene.schema(kind))
        channel = raw.register_channel(topic, "protobuf", schemas[kind])
        for k, (ns, msg, _) in enumerate(msgs):
            raw.add_message(channel, log_time=ns, data=msg.encode(), publish_time=ns, sequence=k)


def _write(writer, rec, stamps, clock_why, topics):
    wrench = writer.register_msgdef(WRENCH_STAMPED, WRENCH_STAMPED_DEF)
    raw = writer._writer  # mcap's own Writer under mcap_ros2's: the JSON channels
    state = raw.register_schema(
        CONTACT_STATE, "jsonschema", json.dumps(CONTACT_STATE_SCHEMA).encode()
    )
    channels = {s: raw.register_channel(contact_topic(s), "json", state) for s in rec.sensors}
    device = rec.meta.get("device")
    wrenches = rec.wrench.tolist()
    rows = zip(
        rec.sensor.tolist(),
        stamps.tolist(),
        rec.seq.tolist(),
        rec.is_contact.tolist(),
        rec.phase.tolist(),
        rec.contact_id.tolist(),
        rec.flags.tolist(),
    )
    for i, (s, ns, seq, is_contact, phase, cid, flags) in enumerate(rows):
        msg = wrench_message(s, ns, wrenches[i])
        writer.write_message(wrench_topic(s), wrench, msg, log_time=ns, sequence=seq)
        c = contact_message(s, ns, seq, is_contact, phase, cid, flags, device)
        data = json.dumps(c, separators=(",", ":")).encode()
        raw.add_message(channels[s], log_time=ns, data=data, publish_time=ns, sequence=seq)
    writer.add_metadata("tactile", _metadata(rec, clock_why, topics))


def _metadata(rec, clock_why, topics):
    c = rec.contacts
    contacts = (
        f"{len(c.points_m)} contacts from contacts.csv (written in {c.file_unit}, here in m);"
        f" stamped at the first frame: contacts.csv has no times"
        if c is not None
        else f"none: {rec.contacts_why}"
    )
    return {
        "tactile_version": __version__,
        "source": str(rec.path),
        "stamps": clock_why,
        "units": "force N, torque N*m, position m (SI, REP 103)",
        "topics": json.dumps(topics),
        "sensor_frames": json.dumps({wrench_topic(s): sensor_frame(s) for s in rec.sensors}),
        "contacts": contacts,
        "contact_arrows": "from each contact point (m) along its normal (object toward probe)",
        "patch_colour": "shape index S at the patch centre: -1 blue, 0 white, +1 red",
        "device": json.dumps(rec.meta.get("device")),
    }
