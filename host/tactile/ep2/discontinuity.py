"""Discontinuities along a finger's sweep (§6.2.2, §6.2.5).

A crease or edge shows as consecutive normals of one finger that differ by
more than an angle.  ``find_breaks`` lists them; ``split_parts`` cuts every
finger's sequence at its breaks and groups the k-th piece of each finger into
part k, so each part can be fitted as its own patch.
"""

import numpy as np

BREAK_ANGLE_DEG = 30.0


def find_breaks(normals, finger, max_angle_deg=BREAK_ANGLE_DEG):
    """List of (row index, finger, angle in deg) where the normal turns too far.

    ``normals`` are unit rows in sweep order within each finger; ``finger``
    labels rows (None: no finger information, nothing is checked).
    """
    if finger is None:
        return []
    finger = np.asarray(finger)
    out = []
    for f in dict.fromkeys(finger.tolist()):
        rows = np.flatnonzero(finger == f)
        if rows.size < 2:
            continue
        dots = np.einsum("ij,ij->i", normals[rows[:-1]], normals[rows[1:]])
        cross = np.linalg.norm(np.cross(normals[rows[:-1]], normals[rows[1:]]), axis=1)
        angle = np.degrees(np.arctan2(cross, dots))
        for j in np.flatnonzero(angle > max_angle_deg):
            out.append((int(rows[j + 1]), f, float(angle[j])))
    return out


def split_parts(n_rows, finger, breaks):
    """Row-index arrays of the parts left after cutting each finger at its breaks."""
    part = np.zeros(n_rows, dtype=int)
    finger = np.asarray(finger)
    cut = {}
    for row, f, _ in breaks:
        cut.setdefault(f, []).append(row)
    for f, rows_cut in cut.items():
        rows = np.flatnonzero(finger == f)
        for r in rows_cut:
            part[rows[rows >= r]] += 1
    return [np.flatnonzero(part == k) for k in range(part.max() + 1) if np.any(part == k)]
