"""The 3D scene Foxglove draws, built once for the live server and the MCAP export.

- ``contacts_update``: ``/tactile/contacts``, one ``SceneEntity`` of arrows in frame
  ``world``, each from a contact point along the object's outward normal (toward the
  probe), ``ARROW_M`` long; positions in m.
- ``sensor_transform``: ``/tactile/tf``, ``world -> tactile_sensorN`` at a pose-log
  window's pose (translation in m, rotation a unit quaternion).
- ``patch_update``: ``/tactile/patch``, the EP2 patch as a ``TriangleListPrimitive`` over the
  contacts' extent (``GRID`` x ``GRID`` cells of the fitted surface) in the colour of its
  centre's shape index S by ``s_colour`` (S = -1 blue, 0 white, +1 red), and a
  ``TextPrimitive`` with the label, S and its 95 % interval; its entity metadata repeat them.
  A refused or ``uncertain`` patch is text only: no mesh where the data do not fix one; a
  plane (S undefined) is grey.

Messages are ``foxglove.messages`` objects (the ``foxglove`` extra, imported when called),
logged on the SDK's typed channels (``Topics.scene``): the same protobuf schema in every sink.
"""

import numpy as np

from tactile.ep2.api import analyze_sweep
from tactile.errors import DataError, InputError, need
from tactile.foxglove.topics import WORLD_FRAME, sensor_frame

ARROW_M = 0.01  # drawn length of a contact normal (m)
GRID = 12  # mesh cells per side
MESH_ALPHA = 0.8
PATCH_ID = "patch"
PLANE_RGB = (0.7, 0.7, 0.7)
EP2_OPTS = dict(grid=8, break_angle=30.0)  # ``tactile ep2 analyze``'s defaults


def _fm():
    return need("foxglove", "the Foxglove scene", "foxglove.messages")[0]


def _stamp(fm, ns):
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return fm.Timestamp(sec, nsec)


def normal_quaternions(normals):
    """(k, 4) quaternions x, y, z, w turning the x axis onto each unit normal: half-way
    between x and n, about x cross n (a half turn about z for n = -x)."""
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    q = np.column_stack([np.zeros(len(n)), -n[:, 2], n[:, 1], 1.0 + n[:, 0]])
    length = np.linalg.norm(q, axis=1)
    flip = length < 1e-9  # n = -x: any half turn about an axis normal to x
    q[flip] = (0.0, 0.0, 1.0, 0.0)
    length[flip] = 1.0
    return q / length[:, None]


def matrix_quaternion(R):
    """Unit quaternion (x, y, z, w) of a rotation matrix (3, 3), w >= 0."""
    R = np.asarray(R, dtype=float)
    w = np.sqrt(max(0.0, 1.0 + np.trace(R))) / 2.0
    x = np.copysign(np.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2.0, R[2, 1] - R[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2.0, R[0, 2] - R[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2.0, R[1, 0] - R[0, 1])
    q = np.array([x, y, z, w])
    return q / np.linalg.norm(q)


def _pose(fm, p, q):
    return fm.Pose(
        position=fm.Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2])),
        orientation=fm.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])),
    )


def contacts_update(entity_id, points_m, normals, ns):
    """A SceneUpdate replacing entity ``entity_id``: an arrow per contact (points in m,
    unit normals), stamped ``ns`` (Unix ns, or the board clock's)."""
    fm = _fm()
    colour = fm.Color(r=1.0, g=0.6, b=0.0, a=1.0)
    arrows = [
        fm.ArrowPrimitive(
            pose=_pose(fm, p, q),
            shaft_length=0.7 * ARROW_M,
            shaft_diameter=0.06 * ARROW_M,
            head_length=0.3 * ARROW_M,
            head_diameter=0.15 * ARROW_M,
            color=colour,
        )
        for p, q in zip(np.asarray(points_m, float), normal_quaternions(normals))
    ]
    entity = fm.SceneEntity(
        timestamp=_stamp(fm, ns), frame_id=WORLD_FRAME, id=str(entity_id), arrows=arrows
    )
    return fm.SceneUpdate(entities=[entity])


def sensor_transform(sensor, R, t_m, ns):
    """FrameTransform world -> tactile_sensorN: rotation ``R`` (3, 3), translation m."""
    fm = _fm()
    q = matrix_quaternion(R)
    return fm.FrameTransform(
        timestamp=_stamp(fm, ns),
        parent_frame_id=WORLD_FRAME,
        child_frame_id=sensor_frame(sensor),
        translation=fm.Vector3(x=float(t_m[0]), y=float(t_m[1]), z=float(t_m[2])),
        rotation=fm.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])),
    )


def s_colour(S):
    """(r, g, b) of shape index S in [-1, 1]: blue (-1, cup) -> white (0, saddle) -> red
    (+1, cap); linear in S on each side."""
    s = float(np.clip(S, -1.0, 1.0))
    return (1.0, 1.0 - s, 1.0 - s) if s >= 0 else (1.0 + s, 1.0 + s, 1.0)


def patch_text(record, n_contacts):
    """One line saying what EP2 found, in the units of the record (m, 1/m)."""
    if record.get("shape") is None:
        return f"EP2: refused ({n_contacts} contacts): {record.get('error')}"
    si = record.get("S_interval")
    interval = "no interval" if si is None else f"95% [{si[0]:.2f}, {si[1]:.2f}]"
    if record["shape"] == "plane":
        return f"EP2: plane ({n_contacts} contacts): no curvature, S undefined"
    if record["shape"] == "uncertain" or record.get("S") is None:
        return f"EP2: uncertain ({n_contacts} contacts): S not determined, {interval}"
    radius = "" if record.get("radius") is None else f", radius {record['radius'] * 1e3:.1f} mm"
    return (
        f"EP2: {record['shape']} ({n_contacts} contacts): S {record['S']:.2f} ({interval}){radius}"
    )


def mesh_colour(record):
    """(r, g, b) of the patch's mesh, or None when none is drawn (refused, uncertain, S
    unknown); a plane, whose S is undefined, is grey."""
    if record.get("shape") == "plane":
        return PLANE_RGB
    if record.get("shape") in (None, "uncertain") or record.get("S") is None:
        return None
    return s_colour(record["S"])


def patch_mesh(result):
    """(k, 3) triangle vertices (m) of a ``PatchResult``'s surface over the contacts' box."""
    x0, x1, y0, y1 = result.domain_box()
    gx, gy = np.meshgrid(np.linspace(x0, x1, GRID + 1), np.linspace(y0, y1, GRID + 1))
    world = result.surface_world(np.column_stack([gx.ravel(), gy.ravel()]))
    world = world.reshape(GRID + 1, GRID + 1, 3)
    a, b, c, d = world[:-1, :-1], world[:-1, 1:], world[1:, :-1], world[1:, 1:]
    tris = np.stack([a, b, d, a, d, c], axis=2)  # two triangles per cell
    return tris.reshape(-1, 3)


def fit_patch(points, normals, finger):
    """(record dict, triangle vertices (k, 3) m or None) of EP2 on the contacts, as
    ``tactile ep2 analyze`` gives for one patch; a refusal is ``{"shape": None, "error"}``."""
    try:
        (result,) = analyze_sweep(points, normals, finger=finger, **EP2_OPTS)
    except (DataError, InputError) as exc:
        return {"shape": None, "n_points": len(points), "error": str(exc)}, None
    record = result.to_dict(1)
    try:
        mesh = patch_mesh(result) if mesh_colour(record) is not None else None
    except (ValueError, FloatingPointError):  # a surface EP2 labelled but cannot evaluate
        mesh = None
    return record, mesh


def patch_update(record, mesh_m, anchor_m, n_contacts, ns):
    """A SceneUpdate replacing the patch entity: the mesh (``mesh_m`` triangle vertices, m;
    None: none drawn) in ``s_colour`` of the record's S, and the text at ``anchor_m``."""
    fm = _fm()
    text = patch_text(record, n_contacts)
    triangles = []
    rgb = mesh_colour(record)
    if mesh_m is not None and rgb is not None:
        r, g, b = rgb
        points = [fm.Point3(x=float(x), y=float(y), z=float(z)) for x, y, z in mesh_m]
        colour = fm.Color(r=r, g=g, b=b, a=MESH_ALPHA)
        triangles = [fm.TriangleListPrimitive(points=points, color=colour)]
    label = fm.TextPrimitive(
        pose=_pose(fm, anchor_m, (0.0, 0.0, 0.0, 1.0)),
        billboard=True,
        font_size=14.0,
        scale_invariant=True,
        color=fm.Color(r=1.0, g=1.0, b=1.0, a=1.0),
        text=text,
    )
    meta = {
        "shape": str(record.get("shape")),
        "S": "null" if record.get("S") is None else repr(float(record["S"])),
        "S_interval": str(record.get("S_interval")),
        "contacts": str(n_contacts),
        "colour_map": "S -1 blue, 0 white, +1 red",
    }
    entity = fm.SceneEntity(
        timestamp=_stamp(fm, ns),
        frame_id=WORLD_FRAME,
        id=PATCH_ID,
        metadata=[fm.KeyValuePair(key=k, value=v) for k, v in meta.items()],
        triangles=triangles,
        texts=[label],
    )
    return fm.SceneUpdate(entities=[entity])
