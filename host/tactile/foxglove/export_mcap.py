"""A recording as an MCAP file, for Foxglove and the ROS 2 tools: the live view's topics,
written through the same declarations (``tactile.foxglove.topics``) into an ``McapSink``
(foxglove-sdk's MCAP writer, MCAP's ``ros2`` profile).

- One topic per sensor, ``/tactile/sensorN/wrench``: a ``geometry_msgs/msg/WrenchStamped``
  per SAMPLE or CONTACT frame, force in N and torque in N*m (ROS's REP 103 units),
  ``header.frame_id`` ``tactile_sensorN``; beside it ``/tactile/sensorN/contact``, the
  frame's contact state and the gate's thresholds (JSON), whose ``seq`` is the frame's
  sequence number.  The live server (``tactile.foxglove.live``) publishes the same topics
  and schemas.
- When the run has a contacts.csv, the live view's scene (``tactile.foxglove.scene``, the
  same ``foxglove.SceneUpdate`` schema, protobuf): ``/tactile/contacts``, one entity of
  arrows in frame ``world`` from every contact point (m) along its normal, and
  ``/tactile/patch``, the EP2 patch of all the contacts (as ``tactile ep2 analyze`` fits
  it) as a mesh coloured by S with its label and interval.  contacts.csv carries no times,
  so both are stamped at the recording's first frame and a player shows them throughout.
  With the robot's pose log, ``/tactile/tf``: a ``foxglove.FrameTransform`` world ->
  tactile_sensorN per pose-log window, stamped at the first frame of that sensor inside it.
- Stamps (``header.stamp`` and each message's log time): the host's UTC (Unix time, as ROS
  stamps) when every row has one (``tactile.recording.load``), else the board's clock
  (seconds since its segment's first frame's epoch: its boot).  The metadata record
  ``tactile`` says which, and why, with the units, topics and source.

foxglove-sdk is the ``export`` extra, imported only here (``require_mcap``); its log lines
go where the live server's go (``tactile.foxglove.topics.sdk``).
"""

import json
import pathlib

import numpy as np

from tactile import __version__
from tactile.files.writing import atomic_write
from tactile.foxglove import scene
from tactile.foxglove.live_scene import entered
from tactile.foxglove.topics import (
    CONTACTS_TOPIC,
    PATCH_TOPIC,
    TF_TOPIC,
    McapSink,
    Topics,
    contact_topic,
    sdk,
    sensor_frame,
    wrench_topic,
)
from tactile.localize.posed import sensor_poses, window_index

__all__ = ["require_mcap", "stamps_ns", "write_mcap"]


def require_mcap():
    """The ``foxglove`` module, or ``MissingExtra`` (the ``export`` extra: foxglove-sdk, its
    MCAP writer and the scene's schemas)."""
    return sdk("export", "MCAP export", "foxglove.messages")[0]


def stamps_ns(rec):
    """(int64 ns per row, "host UTC" or "board clock", a sentence saying which and why)."""
    if rec.host_utc_s is not None and np.isfinite(rec.host_utc_s).all():
        ns = np.round(rec.host_utc_s * 1e6).astype(np.int64) * 1000  # frames.csv: to the us
        return ns, "host UTC", f"host UTC, Unix time (from {rec.host_time_source})"
    ns = np.round(rec.board_time_s * 1e6).astype(np.int64) * 1000
    why = rec.host_time_why or "the recording has no host time"
    if why.startswith("fast mode"):  # (an emulator's: nothing is wrong)
        return ns, "board clock", f"{why}; s since the board's boot"
    return ns, "board clock", f"board clock, s since its boot, not host time: {why}"


def write_mcap(rec, path, pose_log=None):
    """Write ``rec`` (a ``RecordingData``) to the MCAP file ``path``, replacing it whole
    (``tactile.files.writing``); ``pose_log`` (a ``PoseLog``) adds the sensors'
    transforms.  Returns a summary dict (topics and message counts, the stamps' clock and
    why, the patch's record)."""
    fox = require_mcap()
    path = pathlib.Path(path)
    stamps, clock, clock_why = stamps_ns(rec)
    topics = {wrench_topic(s): int(np.sum(rec.sensor == s)) for s in rec.sensors}
    topics.update({contact_topic(s): topics[wrench_topic(s)] for s in rec.sensors})
    scene_msgs = _scene(rec, stamps, pose_log)
    for topic, msgs in scene_msgs.items():
        topics[topic] = len(msgs) if topic != CONTACTS_TOPIC else len(rec.contacts.points_m)
    with atomic_write(path) as fh:  # a disk error: exit 5; not a file there: exit 2
        context = fox.Context()
        with McapSink(fox, context, fh) as sink:  # raises the write that failed, if one did
            channels = Topics(fox, context)
            if _frames(channels, sink, rec, stamps):
                for topic, msgs in scene_msgs.items():
                    for ns, msg, _ in msgs:
                        channels.scene(topic, msg, ns)
                sink.metadata("tactile", _metadata(rec, clock_why, topics))
            channels.close()
    patch = scene_msgs.get(PATCH_TOPIC)
    return {
        "path": str(path),
        "clock": clock,
        "why": clock_why,
        "topics": topics,
        "patch": patch[0][2] if patch else None,
    }


def _frames(channels, sink, rec, stamps):
    """Each frame's wrench and contact state; False, at once, when the file failed."""
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
        channels.frame(s, ns, wrenches[i], seq, is_contact, phase, cid, flags, device)
        if sink.failed:
            return False
    return True


def _scene(rec, stamps, pose_log):
    """{topic: [(ns, message, record or None)]} of the scene topics the run has."""
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
    host = {"utc": rec.host_utc_s, "monotonic": rec.host_monotonic_s}.get(log.clock)
    if log.clock == "board":
        times = rec.board_us.astype(np.int64)
    elif host is not None:
        times = np.where(np.isfinite(host), np.round(np.nan_to_num(host) * 1e6), -1)
    else:
        return []
    rows = window_index(log, times.astype(np.int64), rec.sensor)
    found = entered(rows, rec.sensor, {})
    R, t = sensor_poses(log, [row for _, _, row in found])
    return [
        (int(stamps[i]), scene.sensor_transform(s, R[k], t[k], int(stamps[i])), None)
        for k, (i, s, _) in enumerate(found)
    ]


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
