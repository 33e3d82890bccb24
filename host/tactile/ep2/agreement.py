"""Do the positions and the normals describe one surface?  For a whole stack of patches.

The curvature from the positions alone and from the normals alone (``centre_jet._split_fits``)
must agree within their covariances (test level 1 - ``AGREE``, 5 dof), comparing only the
derivative combinations both row types determine; unless their gap is also large in itself
(curvature gap over ``AGREE_REL`` of the curvature, or tilt gap over ``AGREE_TILT`` rad:
more than model bias on noise-free data reaches), a disagreement is a warning and the
intervals are widened by the gap (a real rig's normals carry friction and calibration
errors); otherwise the patch is refused: the normals contradict the positions (sign,
frame, localisation).

The test is vectorised over the stack: each patch's subspaces are kept as 5 x 5 bases whose
unused columns are zero (a rank that varies per patch), so a patch gives the same numbers
alone or in a batch.  The message of a patch that disagrees is written per patch.
"""

import math

import numpy as np
from scipy.special import fdtri

from tactile.ep2.centre_result import MAX_HALF_WIDTH, direction_text
from tactile.ep2.surface_geometry import eigen, shape_entries

AGREE = 0.99999  # positions vs normals: test level (false alarms 1e-5 per patch)
AGREE_REL = 0.5  # ... and the curvature gap must exceed this share of the curvature
AGREE_TILT = 0.05  # ... or the tilt gap this many rad (3 deg)


def consistency(split, dof, scale, axes):
    """[(refusal or None, warning or None, curvature gap (3,))] per patch of the stack.

    ``split`` = ((d, cov, (blind, scale)) from the positions alone, ... from the normals
    alone), d (B, 5) = (z_x, z_y, z_xx, z_xy, z_yy) at the centre, cov (B, 5, 5), blind
    (B, p, 5) and scale (B, 5) of ``batch_lstsq``; dof (B,), scale (B,) L, axes (B, 3, 3)."""
    (dp, cp, bp), (dn, cn, bn) = split
    seen = _both_determine(_determined(*bp, cp), _determined(*bn, cn))  # (B, 5, 5)
    gap = dp - dn
    d2 = _mahalanobis2(
        np.einsum("bij,bi->bj", seen, gap), np.swapaxes(seen, -1, -2) @ (cp + cn) @ seen
    )
    dof = np.asarray(dof, float)
    crit = 5.0 * fdtri(5, np.where(np.isfinite(dof), np.maximum(dof, 1.0), 1e9), AGREE)
    agree = ~seen.any(axis=(1, 2)) | (d2 <= crit)
    out = []
    for i in range(len(gap)):
        if agree[i]:
            out.append((None, None, np.zeros(3)))
        else:
            out.append(_disagreement(dp[i], dn[i], float(d2[i]), float(scale[i]), axes[i]))
    return out


def _disagreement(dp, dn, d2, scale, axes):
    """(refusal, None, gap) or (None, warning, curvature gap) of one patch that disagrees."""
    gap = dp - dn
    tp, tn = (np.array(shape_entries(*d)) for d in (dp, dn))
    # round-off zeros print as 0 (a batch and a single patch differ there, nowhere else):
    # under 1e-12 of the largest curvature, or of 1/L where every curvature is round-off
    top = max(float(np.abs(np.array([tp, tn])).max()), 1.0)
    kp, kn = (_clean(np.array(eigen(*t)), top) / scale for t in (tp, tn))
    tilt = math.degrees(math.atan(math.hypot(gap[0], gap[1])))
    most = _where_most(tp, tn, axes, scale, top) if np.any(_clean(tp - tn, top)) else ""
    text = (
        "positions and normals disagree: the positions give curvatures"
        f" ({kp[0]:.3g}, {kp[1]:.3g}) per unit length, the normals ({kn[0]:.3g}, {kn[1]:.3g})"
        f"{most}, tilts {tilt:.1f} deg apart ({math.sqrt(d2):.1f} sd)"
    )
    big = _norm(tp - tn) > AGREE_REL * max(_norm(tp), _norm(tn))
    if big or math.radians(tilt) > AGREE_TILT:
        return text + "; check the normals' sign and frame or the contact localisation", None, gap
    return None, text + "; intervals widened to hold both", tp - tn


def _clean(k, top):
    """``k`` with the entries under 1e-12 ``top`` (round-off) set to 0."""
    return np.where(np.abs(k) <= 1e-12 * top, 0.0, k)


def _where_most(tp, tn, axes, scale, top):
    """Text: the normal curvatures of both estimates along the tangent direction where
    they differ most (tells a mirrored saddle, whose principal curvatures agree, apart)."""
    a, b, c = tp - tn
    w, v = np.linalg.eigh(np.array([[a, b], [b, c]]))
    u = v[:, int(np.argmax(np.abs(w)))]
    kp, kn = (float(_clean(u @ np.array([[t[0], t[1]], [t[1], t[2]]]) @ u, top)) for t in (tp, tn))
    kp, kn = kp / scale, kn / scale
    d = u[0] * axes[0] + u[1] * axes[1]
    return f", along {direction_text(d)} {kp:.3g} vs {kn:.3g}"


def _determined(blind, scale, cov):
    """Orthonormal bases (B, 5, 5) (unused columns zero) of the derivative combinations u
    one row type determines: in its span (blind @ (u / scale) = 0, ``batch_lstsq.Solution``)
    and to the standard a curvature must meet (95 % half-width <= ``MAX_HALF_WIDTH``).  A
    formally full but ill-conditioned fit (two fingers whose lines are nearly, not exactly,
    straight in the patch frame) amplifies model bias far beyond its noise: not compared."""
    _, sv, vt = np.linalg.svd(blind)
    rank = np.sum(sv > 1e-8, axis=-1)
    # the null space, vt's rows rank..4, as the first 5 - rank columns (zero beyond)
    pick = (rank[:, None] + np.arange(5)) % 5
    used = np.arange(5) < (5 - rank)[:, None]
    v = np.swapaxes(np.take_along_axis(vt, pick[:, :, None], axis=1), -1, -2) * used[:, None, :]
    q, _ = np.linalg.qr(v * scale[:, :, None])
    q = q * used[:, None, :]
    inner = np.swapaxes(q, -1, -2) @ cov @ q
    k = np.arange(5)
    inner[:, k, k] += np.where(used, 0.0, 1.0)  # unused: a unit variance, never kept
    w, V = np.linalg.eigh(inner)
    in_used = np.sum(V * V * used[:, :, None], axis=1) > 0.5
    keep = (1.96 * np.sqrt(np.maximum(w, 0.0)) <= MAX_HALF_WIDTH) & in_used
    return (q @ V) * keep[:, None, :]


def _both_determine(qa, qb):
    """Orthonormal bases (B, 5, 5) (unused columns zero) of the intersection of two
    subspaces given by such bases."""
    eye = np.eye(qa.shape[-2])
    stacked = np.concatenate(
        [eye - qa @ np.swapaxes(qa, -1, -2), eye - qb @ np.swapaxes(qb, -1, -2)], axis=-2
    )
    _, sv, vt = np.linalg.svd(stacked)
    rank = np.sum(sv > 1e-6, axis=-1)
    return np.swapaxes(vt, -1, -2) * (np.arange(vt.shape[-1]) >= rank[:, None])[:, None, :]


def _norm(t):
    return math.sqrt(t[0] ** 2 + 2 * t[1] ** 2 + t[2] ** 2)


def _mahalanobis2(v, cov):
    """v^T cov^+ v per patch, over the directions cov resolves: v (B, k), cov (B, k, k)."""
    w, V = np.linalg.eigh(cov)
    keep = w > 1e-12 * np.maximum(w.max(axis=-1), 1e-300)[:, None]
    proj = np.einsum("bij,bi->bj", V, v)
    return np.sum(np.where(keep, proj * proj / np.where(keep, w, 1.0), 0.0), axis=-1)
