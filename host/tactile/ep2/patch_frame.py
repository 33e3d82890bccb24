"""World frame -> patch frame and back (§4.1 step 2, §5.1.2).

The patch frame's z axis is the outward mean normal (normals point from the
object toward the finger), its origin the centroid of the contacts, its x axis
the world x axis projected onto the tangent plane (world y if x is nearly
normal).  In that frame slopes dz/dx = -nx/nz, dz/dy = -ny/nz stay finite.
"""

from dataclasses import dataclass

import numpy as np

from tactile.errors import DataError

MAX_NORMAL_ANGLE_DEG = 80.0


@dataclass(frozen=True)
class PatchFrame:
    """Rigid frame: ``rot`` rows are the patch x, y, z axes in world coordinates."""

    origin: np.ndarray
    rot: np.ndarray

    def to_patch(self, points):
        return (np.asarray(points, float) - self.origin) @ self.rot.T

    def to_patch_dirs(self, vectors):
        return np.asarray(vectors, float) @ self.rot.T

    def to_world(self, points):
        return np.asarray(points, float) @ self.rot + self.origin

    def to_world_dirs(self, vectors):
        return np.asarray(vectors, float) @ self.rot

    def rotated_about_z(self, angle):
        """The same frame turned by ``angle`` (rad) about its own z axis (§4.10 refit)."""
        c, s = np.cos(angle), np.sin(angle)
        turn = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        return PatchFrame(self.origin, turn @ self.rot)


def unit_normals(normals):
    """Normalise rows; zero-length rows raise ``DataError`` naming the row index."""
    n, ok = unit_rows(normals)
    bad = np.flatnonzero(~ok)
    if bad.size:
        raise DataError(f"normal of contact {bad[0]} has zero length")
    return n


def unit_rows(normals):
    """(rows (..., 3) made unit, (...) whether each was non-zero: a zero or non-finite row
    is left as it is).  A row far from unit length (1e-300 or 1e300) is first divided by
    its largest component, so the squares in its norm neither overflow nor underflow."""
    n = np.asarray(normals, float)
    big = np.max(np.abs(n), axis=-1) if n.size else np.zeros(n.shape[:-1])
    ok = (big > 0) & (big < np.inf)
    big = np.where(ok, big, 1.0)[..., None]
    n = np.where((big > 1e-100) & (big < 1e100), n, n / big)
    norm = np.linalg.norm(n, axis=-1)[..., None]
    return np.where(ok[..., None], n / np.where(ok[..., None], norm, 1.0), n), ok


def frame_from_contacts(points, normals):
    """Patch frame from contacts and UNIT normals (z = normalised mean normal)."""
    mean = normals.mean(axis=0)
    norm = np.linalg.norm(mean)
    if norm < 1e-6:
        raise DataError(
            "normals inconsistent with one patch: they cancel out (mean normal is zero)"
        )
    ez = mean / norm
    ref = np.array([1.0, 0.0, 0.0]) if abs(ez[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    ex = ref - (ref @ ez) * ez
    ex /= np.linalg.norm(ex)
    ey = np.cross(ez, ex)
    return PatchFrame(np.asarray(points, float).mean(axis=0), np.vstack([ex, ey, ez]))


def slopes(normals_patch, max_angle_deg=MAX_NORMAL_ANGLE_DEG, lines=None):
    """dz/dx = -nx/nz, dz/dy = -ny/nz (§4.5.1) for unit normals in the patch frame.

    A normal more than ``max_angle_deg`` from the patch z axis makes the
    height-field model unusable there: ``DataError`` naming the contact.
    """
    nz = normals_patch[:, 2]
    limit = np.cos(np.radians(max_angle_deg))
    bad = np.flatnonzero(nz < limit)
    if bad.size:
        i = bad[0]
        angle = np.degrees(np.arccos(np.clip(nz[i], -1.0, 1.0)))
        where = f"line {lines[i]}" if lines is not None else f"contact {i}"
        raise DataError(
            f"normals inconsistent with one patch: {where} is {angle:.1f} deg from the mean normal"
            f" (limit {max_angle_deg:g} deg; split the sweep or check the normals' sign)"
        )
    return -normals_patch[:, 0] / nz, -normals_patch[:, 1] / nz
