"""The topics and schemas Foxglove sees, declared once for the live server
(``tactile.output.foxglove_live``) and the MCAP export (``tactile.recording.export_mcap``).

- ``/tactile/sensorN/wrench``: ROS 2 ``geometry_msgs/msg/WrenchStamped`` (schema encoding
  ``ros2msg``, messages CDR), force in N and torque in N*m, ``header.frame_id``
  ``tactile_sensorN``.  Foxglove has no wrench schema of its own; its Plot panel reads
  ``.wrench.force.x`` and the ROS 2 tools read the recording as is.
- ``/tactile/sensorN/contact``: ``tactile/ContactState`` (JSON, described by a JSON
  Schema): the frame's contact state beside the gate's thresholds, units in the names.
- ``/tactile/contacts``, ``/tactile/patch``: ``foxglove.SceneUpdate``; ``/tactile/tf``:
  ``foxglove.FrameTransform`` (protobuf, the SDK's own schemas; built by
  ``tactile.recording.scene``): the localised contacts as arrows along their normals, the
  latest EP2 patch, and each sensor's pose from the robot's pose log.

The builders return plain dicts: the ROS 2 ones are CDR-encoded by ``mcap_ros2`` (the same
encoder in both sinks), the JSON one is written as JSON.
"""

from tactile_protocol import constants as C

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
CONTACTS_TOPIC = "/tactile/contacts"  # foxglove.SceneUpdate: arrows, m
PATCH_TOPIC = "/tactile/patch"  # foxglove.SceneUpdate: mesh and text, m
TF_TOPIC = "/tactile/tf"  # foxglove.FrameTransform: world -> tactile_sensorN, m
SCENE_TOPICS = (CONTACTS_TOPIC, PATCH_TOPIC, TF_TOPIC)
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


def wrench_topic(sensor):
    return f"/tactile/sensor{sensor}/wrench"


def contact_topic(sensor):
    return f"/tactile/sensor{sensor}/contact"


def sensor_frame(sensor):
    return f"tactile_sensor{sensor}"


def ros_time(ns):
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nsec}


def wrench_message(sensor, ns, wrench):
    """A WrenchStamped dict: ``wrench`` = (fx, fy, fz) in N then (tx, ty, tz) in N*m."""
    return {
        "header": {"stamp": ros_time(ns), "frame_id": sensor_frame(sensor)},
        "wrench": {
            "force": dict(zip("xyz", map(float, wrench[:3]))),
            "torque": dict(zip("xyz", map(float, wrench[3:6]))),
        },
    }


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
