"""A recording as an MCAP file of ROS 2 messages, for Foxglove and the ROS 2 tools.

- One topic per sensor, ``/tactile/sensorN/wrench``: a ``geometry_msgs/msg/WrenchStamped``
  per SAMPLE or CONTACT frame, force in N and torque in N*m (ROS's REP 103 units),
  ``header.frame_id`` ``tactile_sensorN``.
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
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
POSE_ARRAY_DEF = SEP.join(
    [
        "std_msgs/Header header\ngeometry_msgs/Pose[] poses\n",
        HEADER,
        TIME,
        "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\n"
        "geometry_msgs/Quaternion orientation\n",
        "MSG: geometry_msgs/Point\n" + VECTOR,
        "MSG: geometry_msgs/Quaternion\n" + VECTOR + "float64 w\n",
    ]
)
CONTACTS_TOPIC = "/tactile/contacts"
WORLD_FRAME = "world"


def require_mcap():
    """The ROS 2 MCAP ``Writer`` class, or ``MissingExtra`` (the ``export`` extra: mcap,
    mcap-ros2-support)."""
    return need("export", "MCAP export", "mcap_ros2.writer")[0].Writer


def wrench_topic(sensor):
    return f"/tactile/sensor{sensor}/wrench"


def sensor_frame(sensor):
    return f"tactile_sensor{sensor}"


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


def _time(ns):
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nsec}


def _contacts_message(contacts, stamp):
    q = normal_quaternions(contacts.normals)
    poses = [
        {
            "position": dict(zip("xyz", map(float, p))),
            "orientation": dict(zip("xyzw", map(float, o))),
        }
        for p, o in zip(contacts.points_m, q)
    ]
    return {"header": {"stamp": _time(stamp), "frame_id": WORLD_FRAME}, "poses": poses}


def write_mcap(rec, path):
    """Write ``rec`` (a ``RecordingData``) to the MCAP file ``path``, replacing it whole
    (written beside it, then renamed).  Returns a summary dict (topics and message counts,
    the stamps' clock and why)."""
    Writer = require_mcap()
    path = pathlib.Path(path)
    stamps, clock, clock_why = stamps_ns(rec)
    topics = {wrench_topic(s): int(np.sum(rec.sensor == s)) for s in rec.sensors}
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
    frames = {s: sensor_frame(s) for s in rec.sensors}
    force, torque = rec.force_N.tolist(), rec.torque_Nm.tolist()
    for i, (s, ns, seq) in enumerate(zip(rec.sensor.tolist(), stamps.tolist(), rec.seq.tolist())):
        msg = {
            "header": {"stamp": _time(ns), "frame_id": frames[s]},
            "wrench": {"force": dict(zip("xyz", force[i])), "torque": dict(zip("xyz", torque[i]))},
        }
        writer.write_message(wrench_topic(s), wrench, msg, log_time=ns, sequence=seq)
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
