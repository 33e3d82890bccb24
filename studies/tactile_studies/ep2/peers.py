"""The trust bench's peer (bench/ep2_trust.py), on the same contacts as the estimator.

``jet``: quadric (2-jet) least squares z = c + g.x + x^T A x / 2 about the patch centre,
curvature at the centre; ``with_normals`` adds the slope rows weighted 1/sigma as in the
main fit.  It works in the patch frame of ``tactile.ep2.geometry`` and takes its
curvature from ``tactile.ep2.geometry``, so only the surface estimate differs.
"""

import numpy as np

from tactile.ep2 import geometry
from tactile.ep2.geometry import curvatures


def _framed(points, normals):
    nrm = geometry.unit_normals(normals)
    frame = geometry.frame_from_contacts(points, nrm)
    p = frame.to_patch(points)
    sx, sy = geometry.slopes(frame.to_patch_dirs(nrm), 89.0)
    return p, sx, sy


def jet(points, normals, noise_pos=1.0, noise_normal=1.0, with_normals=True):
    """(k1, k2) at the patch centre from a 2-jet (quadric) least-squares fit."""
    p, sx, sy = _framed(points, normals)
    c = 0.5 * (p.min(axis=0) + p.max(axis=0))
    x, y, z = p[:, 0] - c[0], p[:, 1] - c[1], p[:, 2]
    one, zero = np.ones_like(x), np.zeros_like(x)
    rows = [np.column_stack([one, x, y, 0.5 * x * x, x * y, 0.5 * y * y])]
    rhs = [z]
    w = [np.full(len(x), 1.0 / max(noise_pos, 1e-12))]
    if with_normals:
        rows += [
            np.column_stack([zero, one, zero, x, y, zero]),
            np.column_stack([zero, zero, one, zero, x, y]),
        ]
        rhs += [sx, sy]
        w += [np.full(len(x), 1.0 / max(noise_normal, 1e-12))] * 2
    A = np.vstack(rows) * np.concatenate(w)[:, None]
    b = np.concatenate(rhs) * np.concatenate(w)
    coef = np.linalg.lstsq(A, b, rcond=None)[0]
    k1, k2 = curvatures(coef[1], coef[2], coef[3], coef[4], coef[5])
    return np.atleast_1d(k1), np.atleast_1d(k2)
