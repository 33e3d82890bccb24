"""Do a patch's positions and normals describe one surface?  (thesis §4.5 fits both at once,
and so assumes they do.)

Normals given in the wrong frame, flipped, or read off a flat plate describe another surface
than the contacts' positions, and a joint fit follows whichever rows its noise estimate
trusts more, confidently.  So the normals alone are fitted by a 2-jet of slopes, and the
surface it describes (up to a constant) is compared with the positions in data space: they
disagree where the positions' rms gap to it exceeds ``MIN_RATIO`` times its expected size
(the positions' own 2-jet residual and the normals' surface's prediction noise) and
``MIN_GAP``.  A data-space test cannot be fooled by a layout that leaves the positions'
own curvature ill-determined, and a surface no 2-jet follows moves both fits alike.
On the tune split of the families bench: 2 consistent patches of 7,824 refused, none of
2,640 with outliers; 20 of 21 inconsistent reproducers refused (tests).
"""

import math

import numpy as np

from tactile.ep2.jet_terms import design, mv, size

REDUNDANCY = 1.5  # rows per term of each fit alone
MIN_RATIO = 5.0  # the positions' rms gap to the normals' surface, in its expected sizes
MIN_GAP = 2e-3  # of L: a smaller gap is no evidence of anything
TINY = 1e-30


def disagreements(xy, heights, slopes, keep, axes, scale):
    """Per patch None, or the line saying how positions and normals disagree.  xy (B, n, 2)
    and heights (B, n) in the frame / L, slopes (B, n, 2), keep (B, n), axes (B, 3, 3),
    scale (B,) = L."""
    n_kept = keep.sum(-1)
    out = [None] * len(keep)
    idx = np.flatnonzero(REDUNDANCY * size(2) <= n_kept)
    if not len(idx):
        return out
    xy, z, s, w = xy[idx], heights[idx], slopes[idx], keep[idx].astype(float)
    V, DX, DY = design(xy[..., 0], xy[..., 1], 2)
    tp, _, rp, okp = _fit(V * w[..., None], z * w)
    A = np.concatenate([DX, DY], 1)[..., 1:] * np.tile(w, 2)[..., None]
    tn, Cn, _, okn = _fit(A, np.concatenate([s[..., 0], s[..., 1]], 1) * np.tile(w, 2))
    pred = mv(V[..., 1:], tn)  # the normals' surface at the contacts, up to a constant
    gap = (z - pred) * w
    gap = (gap - (gap.sum(-1) / n_kept[idx])[:, None]) * w
    var_p = np.sum(rp * rp, -1) / np.maximum(n_kept[idx] - size(2), 1)
    var_pred = np.einsum("bnp,bpq,bnq->bn", V[..., 1:], Cn, V[..., 1:])
    stat = np.sum(gap * gap / (var_p[:, None] + var_pred + TINY), -1) / n_kept[idx]
    rms = np.sqrt(np.sum(gap * gap, -1) / n_kept[idx])
    bad = okp & okn & (stat > MIN_RATIO**2) & (rms > MIN_GAP)
    for k in np.flatnonzero(bad):
        out[int(idx[k])] = _verdict(tp[k], tn[k], float(rms[k]), axes[idx[k]], float(scale[idx[k]]))
    return out


def _fit(A, b):
    """(coef[first 5 after any constant], cov of all coefs, residuals, determined) of
    least squares A c = b for a stack; the noise from the residuals."""
    cn = np.sqrt(np.sum(A * A, 1))
    cn = np.where(cn > 0, cn, 1.0)
    Q, R = np.linalg.qr(A / cn[:, None, :])
    d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    tiny = ~(d > 1e-9 * d.max(-1, keepdims=True))
    R = R + np.eye(R.shape[-1]) * tiny[:, None, :]  # (a patch not determined: not compared)
    qb = (b[:, None, :] @ Q)[:, 0]
    resid = b - mv(Q, qb)
    rows = np.sum(A != 0, -1) > 0
    dof = np.maximum(rows.sum(-1) - A.shape[2], 1)
    s2 = np.sum(resid * resid, -1) / dof
    Rinv = np.linalg.inv(R) / cn[:, :, None]
    coef = mv(Rinv, qb)
    cov = Rinv @ np.swapaxes(Rinv, -1, -2) * s2[:, None, None]
    lo = A.shape[2] - 5
    return coef[:, lo:], cov[:, lo:, lo:], resid, ~tiny.any(-1)


def _verdict(tp, tn, rms, axes, L):
    """The line: where the two surfaces' curvatures differ most, or their tilt."""
    Hp, Hn = _hessian(tp), _hessian(tn)
    lam, vec = np.linalg.eigh(Hp - Hn)
    u = vec[:, int(np.argmax(np.abs(lam)))]
    kp, kn = -(u @ Hp @ u) / L, -(u @ Hn @ u) / L  # k = -z'' (convex toward +z: k > 0)
    tilt = math.degrees(math.atan(float(np.linalg.norm(tp[:2] - tn[:2]))))
    along = ", ".join(f"{v:.2f}" for v in u @ axes[:2])
    return (
        f"positions and normals disagree: the positions lie {rms:.2g} of the patch size (rms) "
        f"off the surface the normals describe (curvature along ({along}) {kp:.3g} from the "
        f"positions vs {kn:.3g} from the normals, 1/unit; tilt {tilt:.0f} deg); check the "
        "normals' sign and frame, or take a smaller patch where the surface bends this much"
    )


def _hessian(t):
    return np.array([[t[2], t[3]], [t[3], t[4]]])
