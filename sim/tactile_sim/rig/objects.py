"""Objects for the rig: any shape with a signed distance and an outward normal.

The interface is one method, ``distance(p) -> (d, n)`` for points (..., 3): ``d`` < 0 inside
the material, ``n`` the unit outward normal (from the material toward free space, i.e.
toward the probe) of the nearest surface point.  The ch. 5 objects have vertical axes, so
the probe's x-y forces carry the curvature (§5.1.1): a wall (plane), a convex cylinder of
radius 6.6 cm and a concave cylinder (inside of a pipe) of radius 11.25 cm (§5.2).
A sphere is included to show that other shapes plug in.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["Plane", "VerticalCylinder", "Sphere", "ch5_object", "CH5_OBJECTS", "ray_hit"]


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class Plane:
    point: tuple
    normal: tuple  # outward

    def distance(self, p):
        n = _unit(self.normal)
        d = (np.asarray(p, float) - np.asarray(self.point, float)) @ n
        return d, np.broadcast_to(n, np.shape(p)).copy()


@dataclass(frozen=True)
class VerticalCylinder:
    """Cylinder with its axis along world z through ``axis_xy``; ``concave`` = the inside
    of a pipe (material outside the radius, normal toward the axis)."""

    axis_xy: tuple
    radius: float
    concave: bool = False

    def distance(self, p):
        p = np.asarray(p, dtype=float)
        rel = p[..., :2] - np.asarray(self.axis_xy, float)
        rho = np.hypot(rel[..., 0], rel[..., 1])
        radial = rel / np.where(rho > 0.0, rho, 1.0)[..., None]
        radial3 = np.concatenate([radial, np.zeros(rho.shape + (1,))], axis=-1)
        if self.concave:
            return self.radius - rho, -radial3
        return rho - self.radius, radial3


@dataclass(frozen=True)
class Sphere:
    centre: tuple
    radius: float

    def distance(self, p):
        rel = np.asarray(p, dtype=float) - np.asarray(self.centre, float)
        rho = np.linalg.norm(rel, axis=-1)
        return rho - self.radius, rel / np.where(rho > 0.0, rho, 1.0)[..., None]


CH5_OBJECTS = ("plane", "convex", "concave")


def ch5_object(kind, face_x=0.55):
    """The ch. 5 objects, their probed face at x = ``face_x`` facing the robot (-x)."""
    if kind == "plane":
        return Plane((face_x, 0.0, 0.0), (-1.0, 0.0, 0.0))
    if kind == "convex":
        return VerticalCylinder((face_x + 0.066, 0.0), 0.066)
    if kind == "concave":
        return VerticalCylinder((face_x - 0.1125, 0.0), 0.1125, concave=True)
    raise ValueError(f"unknown ch. 5 object {kind!r}; choose from {', '.join(CH5_OBJECTS)}")


def ray_hit(obj, start, direction, length, steps=256):
    """First surface crossing on the segment start + s direction, s in [0, length]: bisection
    on the sign change of d.  Returns the point, or None when the segment never enters."""
    start = np.asarray(start, float)
    direction = _unit(direction)
    s = np.linspace(0.0, length, steps + 1)
    d, _ = obj.distance(start + s[:, None] * direction)
    inside = np.flatnonzero(d <= 0.0)
    if inside.size == 0:
        return None
    k = inside[0]
    if k == 0:
        return start
    lo, hi = s[k - 1], s[k]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if obj.distance(start + mid * direction)[0] > 0.0:
            lo = mid
        else:
            hi = mid
    return start + hi * direction
