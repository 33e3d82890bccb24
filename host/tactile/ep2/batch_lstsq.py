"""Weighted least squares for a stack of small problems, by SVD (never normal equations).

Each problem is min |w * (A c - b)|^2 with its own A (m, p), b (m,) and row
weights w (m,); a weight of 0 removes a row (padding).  Columns are scaled
to unit norm before the SVD, and singular values below ``RCOND`` times the
largest are dropped, so a rank-deficient problem gets the minimum-norm
solution in the scaled columns and its rank says so; nothing raises.
"""

from dataclasses import dataclass

import numpy as np

RCOND = 1e-10


@dataclass
class Solution:
    """coef (..., p); pinv (..., p, m) maps weighted data to coef, so Cov(coef) = pinv
    diag(noise^2 in weighted units) pinv^T; leverage (..., m) hat-matrix diagonal; rss
    (...,) weighted residual sum of squares; rank (...,); ``blind`` (..., p, p) the projector
    onto the design's null space in the scaled columns (columns / ``scale``): a linear
    functional f of coef is determined by the data iff blind @ (f / scale) = 0."""

    coef: np.ndarray
    pinv: np.ndarray
    leverage: np.ndarray
    rss: np.ndarray
    rank: np.ndarray
    residual: np.ndarray
    blind: np.ndarray = None
    scale: np.ndarray = None


def solve(A, b, w):
    """Solve every problem of the stack: A (..., m, p), b (..., m), w (..., m)."""
    Aw = A * w[..., None]
    bw = b * w
    scale = np.sqrt(np.einsum("...mp,...mp->...p", Aw, Aw))
    scale = np.where(scale > 0, scale, 1.0)
    U, s, Vt = np.linalg.svd(Aw / scale[..., None, :], full_matrices=False)
    keep = s > RCOND * s[..., :1]
    inv_s = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    Ukeep = U * keep[..., None, :]
    pinv = (np.swapaxes(Vt, -1, -2) * inv_s[..., None, :]) @ np.swapaxes(Ukeep, -1, -2)
    pinv = pinv / scale[..., :, None]
    coef = np.einsum("...pm,...m->...p", pinv, bw)
    Vkeep = np.swapaxes(Vt, -1, -2) * keep[..., None, :]
    blind = np.eye(Vt.shape[-1]) - Vkeep @ np.swapaxes(Vkeep, -1, -2)
    residual = bw - np.einsum("...mp,...p->...m", Aw, coef)
    return Solution(
        coef=coef,
        pinv=pinv,
        leverage=np.einsum("...mk,...mk->...m", Ukeep, Ukeep),
        rss=np.einsum("...m,...m->...", residual, residual),
        rank=keep.sum(axis=-1),
        residual=residual,
        blind=blind,
        scale=scale,
    )
