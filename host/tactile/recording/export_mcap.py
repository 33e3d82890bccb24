"""A recording as an MCAP file of ROS 2 messages, for Foxglove and the ROS 2 tools.

- One topic per sensor, ``/tactile/sensorN/wrench``: a ``geometry_msgs/msg/WrenchStamped``
  per SAMPLE or CONTACT frame, force in N and torque in N*m (ROS's REP 103 units),
  ``header.frame_id`` ``tactile_sensorN``; beside it ``/tactile/sensorN/contact``, the
  frame's contact state and the gate's thresholds (JSON, ``tactile.recording.topics``).  The live
  server (``tactile.output.foxglove_live``) publishes the same topics and schemas.
- ``/tactile/contacts`` when the run has a contacts.csv: one ``geometry_msgs/msg/PoseArray``
  in ``frame_id`` ``world`` holding every contact, positions in m and each orientation
  turning the x axis onto the contact normal.  Foxglove's 3D panel draws a PoseArray as
  arrows along x, so the contacts show as their normals with no visualization_msgs; a
  ``sensor_msgs/PointCloud2`` would show the points but not the normals.  contacts.csv
  carries no times, so the one message is stamped at the recording's first frame and a
  player shows it throughout.
- Stamps (``header.stamp`` and each message's log time): the host's UTC (Unix time, as ROS
  stamps) when every row has one (``tactile.recording.load``), else the board's clock
  (seconds since its segment's first frame's epoch: its boot).  The metadata record
  ``tactile`` says which, and why, with the units, topics and source.

The ``mcap`` and ``mcap-ros2-support`` packages are the ``export`` extra, imported only here.
"""

import json
import os
import pathlib

import numpy as np

from tactile import __version__
from tactile.errors import InputError
from tactile.extras import need
from tactile.recording.topics import (
    CONTACT_STATE,
    CONTACT_STATE_SCHEMA,
    CONTACTS_TOPIC,
    POSE_ARRAY,
    POSE_ARRAY_DEF,
    WORLD_FRAME,
    WRENCH_STAMPED,
    WRENCH_STAMPED_DEF,
    contact_message,
    contact_topic,
    ros_time,
    sensor_frame,
    wrench_message,
    wrench_topic,
)

__all__ = ["normal_quaternions", "require_mcap", "stamps_ns", "write_mcap"]


def require_mcap():
    """The ROS 2 MCAP ``Writer`` class, or ``MissingExtra`` (the ``export`` extra: mcap,
    mcap-ros2-support)."""
    return need("export", "MCAP export", "mcap_ros2.writer")[0].Writer


def stamps_ns(rec):
    """(int64 ns per row, "host UTC" or "board clock", a sentence saying which and why)."""
    if rec.host_utc_s is not None and np.isfinite(rec.host_utc_s).all():
        ns = np.round(rec.host_utc_s * 1e6).astype(np.int64) * 1000  # frames.csv: to the us
        return ns, "host UTC", f"host UTC, Unix time (from {rec.host_time_source})"
    ns = np.round(rec.board_time_s * 1e6).astype(np.int64) * 1000
    why = rec.host_time_why or "the recording has no host time"
    return ns, "board clock", f"board clock, s since its boot, not host time: {why}"


def normal_quaternions(normals):
    """(k, 4) quaternions x, y, z, w turning the x axis onto each unit normal: half-way
    between x and n, about x cross n (a half turn about z for n = -x)."""
    n = np.asarray(normals, dtype=float)
    q = np.column_stack([np.zeros(len(n)), -n[:, 2], n[:, 1], 1.0 + n[:, 0]])
    length = np.linalg.norm(q, axis=1)
    flip = length < 1e-9  # n = -x: any half turn about an axis normal to x
    q[flip] = (0.0, 0.0, 1.0, 0.0)
    length[flip] = 1.0
    return q / length[:, None]


def _contacts_message(contacts, stamp):
    q = normal_quaternions(contacts.normals)
    poses = [
        {
            "position": dict(zip("xyz", map(float, p))),
            "orientation": dict(zip("xyzw", map(float, o))),
        }
        for p, o in zip(contacts.points_m, q)
    ]
    return {"header": {"stamp": ros_time(stamp), "frame_id": WORLD_FRAME}, "poses": poses}


def write_mcap(rec, path):
    """Write ``rec`` (a ``RecordingData``) to the MCAP file ``path``, replacing it whole
    (written beside it, then renamed).  Returns a summary dict (topics and message counts,
    the stamps' clock and why)."""
    Writer = require_mcap()
    path = pathlib.Path(path)
    stamps, clock, clock_why = stamps_ns(rec)
    topics = {wrench_topic(s): int(np.sum(rec.sensor == s)) for s in rec.sensors}
    topics.update({contact_topic(s): topics[wrench_topic(s)] for s in rec.sensors})
    if rec.contacts is not None:
        topics[CONTACTS_TOPIC] = len(rec.contacts.points_m)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "wb") as fh:
            writer = Writer(fh)
            _write(writer, rec, stamps, clock_why, topics)
            writer.finish()
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(
            f"{exc.filename or path}: cannot write the MCAP file ({exc.strerror})"
        ) from None
    return {"path": str(path), "clock": clock, "why": clock_why, "topics": topics}


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
    if rec.contacts is not None:
        poses = writer.register_msgdef(POSE_ARRAY, POSE_ARRAY_DEF)
        first = int(stamps.min())
        writer.write_message(CONTACTS_TOPIC, poses, _contacts_message(rec.contacts, first), first)
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
        "contact_orientation": "x axis along the contact normal (object toward probe)",
        "device": json.dumps(rec.meta.get("device")),
    }
