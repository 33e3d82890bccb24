"""Height-field test objects z = h(x, y) with analytic gradients and true curvatures.

Normals point from the object toward the finger (+z side), and principal
curvatures are positive where the surface is convex toward the finger, so a
sphere touched from outside has k1 = k2 = +1/R (issue 3 conventions).
Each object's apex (or reference point) is at ``centre``.  Rotations turn the
object about the z axis: for cylinders ``rotation`` is the angle of the
cylinder axis from the y axis (the sweep direction), so rotation 0 puts the
curvature across the fingers (fig. 24).
"""

from dataclasses import dataclass

import numpy as np

KINDS = ("plane", "cylinder", "concave_cylinder", "sphere", "pit", "saddle", "quadric")


@dataclass(frozen=True)
class HeightField:
    """z = h(x, y); ``true_k`` gives the exact (k1, k2) where known in closed form."""

    kind: str
    k: tuple  # principal curvatures (k1 >= k2) along the object's own axes
    rotation: float  # rad
    centre: tuple
    slope: tuple = (0.0, 0.0)
    exact: bool = True  # sphere/cylinder surfaces (True) or quadric height fields

    def _local(self, x, y):
        c, s = np.cos(self.rotation), np.sin(self.rotation)
        dx = np.asarray(x, float) - self.centre[0]
        dy = np.asarray(y, float) - self.centre[1]
        return c * dx + s * dy, -s * dx + c * dy, c, s

    def height(self, x, y):
        return self.eval(x, y)[0]

    def eval(self, x, y):
        """(z, dz/dx, dz/dy) in the world frame."""
        u, v, c, s = self._local(x, y)
        z, zu, zv = _profile(self, u, v)
        zx = c * zu - s * zv + self.slope[0]
        zy = s * zu + c * zv + self.slope[1]
        z = z + self.slope[0] * np.asarray(x, float) + self.slope[1] * np.asarray(y, float)
        return z, zx, zy

    def normals(self, x, y):
        _, zx, zy = self.eval(x, y)
        n = np.stack([-zx, -zy, np.ones_like(zx)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def true_k(self):
        """(k1, k2) everywhere for planes/spheres/cylinders; at the apex for quadrics."""
        return max(self.k), min(self.k)

    def true_s(self):
        k1, k2 = self.true_k()
        if k1 == 0 and k2 == 0:
            return None
        return float(2 / np.pi * np.arctan2(k1 + k2, k1 - k2))


def _profile(obj, u, v):
    """Height along the object's axes: u across, v along (for cylinders)."""
    ku, kv = obj.k
    if obj.kind == "plane":
        zero = np.zeros_like(u)
        return zero, zero, zero
    if obj.exact:
        if ku != 0 and kv != 0:  # sphere (ku = kv) or pit
            return _cap(np.hypot(u, v), 1.0 / ku, u, v)
        if ku != 0:  # cylinder along v
            z, dz, _ = _cap(np.abs(u), 1.0 / ku, u, np.zeros_like(u))
            return z, dz, np.zeros_like(u)
    # quadric height field z = -(ku u^2 + kv v^2)/2: convex toward +z for k > 0
    return -0.5 * (ku * u * u + kv * v * v), -ku * u, -kv * v


def _cap(r, radius, u, v):
    """Spherical/cylindrical cap z = sign*(sqrt(R^2 - r^2) - R), R = |radius|."""
    big = abs(radius)
    sign = 1.0 if radius > 0 else -1.0
    if np.any(r >= big):
        raise ValueError(
            f"sweep reaches beyond the object (radius {big:g} <= distance {np.max(r):g})"
        )
    root = np.sqrt(big * big - r * r)
    # sqrt(R^2 - r^2) - R = -r^2 / (sqrt(R^2 - r^2) + R): no cancellation at large R
    z = -sign * r * r / (root + big)
    return z, -sign * u / root, -sign * v / root


def make(kind, radius=10.0, rotation_deg=0.0, centre=(2.0, 2.0), k=None, slope=(0.0, 0.0)):
    """Build an object by name (``KINDS``); ``k`` = (k1, k2) for ``quadric``."""
    rot = np.radians(rotation_deg)
    inv = 1.0 / radius
    table = {
        "plane": ((0.0, 0.0), True),
        "cylinder": ((inv, 0.0), True),
        "concave_cylinder": ((-inv, 0.0), True),
        "sphere": ((inv, inv), True),
        "pit": ((-inv, -inv), True),
        "saddle": ((inv, -inv), False),
        "quadric": (tuple(k) if k is not None else (inv, 0.5 * inv), False),
    }
    if kind not in table:
        raise ValueError(f"unknown object {kind!r} (choose {', '.join(KINDS)})")
    kk, exact = table[kind]
    return HeightField(kind, kk, rot, tuple(centre), tuple(slope), exact)
