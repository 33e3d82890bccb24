"""Contact localisation from F/T readings (§5.1.1, §3.3.3) and the map to the world (eq. 62).

Conventions (docs/localize.md): wrenches are the load ON THE PROBE (ATI's convention) in the
sensor frame, moments about the sensor origin; returned normals are the OBJECT's outward
normals (from the object toward the probe), as the EP2 contacts CSV expects.  The robot's
pose log is read by ``tactile.logs.pose``; which CONTACT frames are readings is
``readings``.
"""

from tactile.localize.contact import STATUS, Contact
from tactile.localize.contacts_csv import format_contacts
from tactile.localize.kinematics import (
    eq62,
    pose_from_matrix,
    pose_from_quaternion,
    scara_pose,
    to_world,
)
from tactile.localize.pipeline import posed_contacts, scara_contacts
from tactile.localize.posed import posed_world_contacts, sensor_poses
from tactile.localize.readings import Readings, contact_frames
from tactile.localize.sphere import sphere_contact, sphere_contact_frictionless
from tactile.localize.wheel import rim_contact, wheel_contact, wheel_theta

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
