"""Contact localisation from F/T readings (§5.1.1, §3.3.3) and the map to the world (eq. 62).

Conventions (docs/localize.md): wrenches are the load ON THE PROBE (ATI's convention) in the
sensor frame, moments about the sensor origin; returned normals are the OBJECT's outward
normals (from the object toward the probe), as the EP2 contacts CSV expects.  The robot's
pose log is read by ``tactile.logs.read``; which CONTACT frames are readings is
``readings``.
"""

from tactile.localize.contact import STATUS, Contact, Readings, contact_frames
from tactile.localize.posed import posed_world_contacts, sensor_poses
from tactile.localize.probes import (
    rim_contact,
    sphere_contact,
    sphere_contact_frictionless,
    wheel_contact,
    wheel_theta,
)
from tactile.localize.world import (
    eq62,
    format_contacts,
    pose_from_matrix,
    pose_from_quaternion,
    posed_contacts,
    scara_contacts,
    scara_pose,
    to_world,
)

__all__ = [
    "Contact",
    "STATUS",
    "format_contacts",
    "eq62",
    "pose_from_matrix",
    "pose_from_quaternion",
    "scara_pose",
    "to_world",
    "sphere_contact",
    "sphere_contact_frictionless",
    "scara_contacts",
    "posed_contacts",
    "posed_world_contacts",
    "sensor_poses",
    "Readings",
    "contact_frames",
    "rim_contact",
    "wheel_contact",
    "wheel_theta",
]
