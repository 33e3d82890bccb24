"""The centre jet's frames (``centre_jet`` step 1 and 3), for a stack of patches.

The mean-normal frame of each patch (its mean normal as z, the centroid as origin: as
``patch_frame.frame_from_contacts``, with a row mask), the checks it allows (normals
too far from the mean, contacts at one point), and the osculating frame of a fit.
"""

import numpy as np

MAX_REFRAME_DEG = 45.0  # the osculating frame may turn this far from the mean normal, no more


def mean_frame(points, normals, mask, reason):
    """(origin, rotation) per patch as ``patch_frame.frame_from_contacts``, masked."""
    w = mask[..., None]
    count = np.maximum(mask.sum(axis=1), 1)[:, None]
    mean = (normals * w).sum(axis=1) / count
    norm = np.linalg.norm(mean, axis=1)
    for b in np.flatnonzero(~(norm >= 1e-6)):
        reason[b] = "normals inconsistent with one patch: they cancel out (mean normal is zero)"
    ez = mean / np.where(norm >= 1e-6, norm, 1.0)[:, None]
    ez[~(norm >= 1e-6)] = (0.0, 0.0, 1.0)
    ref = np.where(np.abs(ez[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    ex = ref - np.sum(ref * ez, axis=1, keepdims=True) * ez
    ex /= np.linalg.norm(ex, axis=1, keepdims=True)
    ey = np.cross(ez, ex)
    origin = (points * w).sum(axis=1) / count
    return origin, np.stack([ex, ey, ez], axis=1)


def reframe(O, M, L, p, nrm, coef):
    """Move to the osculating frame of ``coef`` at the centre: origin on the fitted surface,
    z along its normal, x the old x projected (same rule as the mean frame)."""
    gx, gy = coef[:, 1], coef[:, 2]
    ez = np.stack([-gx, -gy, np.ones_like(gx)], axis=1)
    ez /= np.linalg.norm(ez, axis=1, keepdims=True)
    # a fit that tilts the normal at the centre this far from the mean normal is not
    # determined there (one line, say): keep the frame rather than turn it by its guess
    steady = ez[:, 2] < np.cos(np.radians(MAX_REFRAME_DEG))
    ez[steady] = (0.0, 0.0, 1.0)
    coef = np.where(steady[:, None], 0.0, coef)
    ex = np.array([1.0, 0.0, 0.0]) - ez[:, :1] * ez
    ex /= np.linalg.norm(ex, axis=1, keepdims=True)
    R = np.stack([ex, np.cross(ez, ex), ez], axis=1)
    shift = np.zeros_like(O)
    shift[:, 2] = coef[:, 0]
    p = np.einsum("bij,bnj->bni", R, p - shift[:, None, :])
    nrm = np.einsum("bij,bnj->bni", R, nrm)
    O = O + L[:, None] * np.einsum("bi,bij->bj", shift, M)
    return O, R @ M, p, nrm


def check_angles(nrm, mask, max_angle_deg, reason):
    bad = mask & ~(nrm[..., 2] >= np.cos(np.radians(max_angle_deg)))
    for b in np.flatnonzero(bad.any(axis=1)):
        i = int(np.flatnonzero(bad[b])[0])
        angle = np.degrees(np.arccos(np.clip(nrm[b, i, 2], -1.0, 1.0)))
        reason[b] = reason[b] or (
            f"normals inconsistent with one patch: contact {i} is {angle:.1f} deg from the mean"
            f" normal (limit {max_angle_deg:g} deg; analyse a smaller patch, pass"
            " --max-normal-angle, or check the normals' sign)"
        )


def size(p, mask, reason):
    ext = masked_max(p, mask) - masked_min(p, mask)
    L = np.maximum(ext[:, 0], ext[:, 1])
    for b in np.flatnonzero(~(L > 0)):
        reason[b] = reason[b] or (
            "all contacts at one point: the patch needs contacts spread in two directions"
        )
    return np.where(L > 0, L, 1.0)


def masked_min(p, mask):
    return np.where(mask[..., None], p, np.inf).min(axis=1)


def masked_max(p, mask):
    return np.where(mask[..., None], p, -np.inf).max(axis=1)
