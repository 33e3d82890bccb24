"""Weighted least squares for a stack of small problems: CholeskyQR2, SVD where it matters.

Each problem is min |w * (A c - b)|^2 with its own A (m, p), b (m,) and row
weights w (m,); a weight of 0 removes a row (padding).  Columns are scaled
to unit norm first.  A column that is zero (every row removed, or switched off by the
caller) is structurally blind: its coefficient is 0 and its direction is in ``blind``.

Well-conditioned problems are factorised by CholeskyQR2 (X = Q R from the Cholesky factor
of X^T X, applied twice): Q is orthonormal to round-off and R as accurate as Householder's
while cond(X) stays below ~1e8 (Yamamoto et al., ETNA 44, 2015); it is a handful of
batched matmuls, where LAPACK's SVD is one call per tiny matrix (``bench/ep2_speed.py``).
A problem whose first Cholesky factor fails or gives cond(X) over ``FAST_MAX_COND``
(Frobenius estimate, within a factor p of the 2-norm one) goes to the SVD: singular
values below ``RCOND`` times the largest are dropped, so a rank-deficient problem gets
the minimum-norm solution in the scaled columns and its rank says so; a problem with
non-finite numbers has rank 0 and NaN coefficients; nothing raises.
Never the normal equations' solution itself: the Gram matrix only yields R, and the
second pass removes the loss of orthogonality that its squared condition brings.
"""

from dataclasses import dataclass, field

import numpy as np

RCOND = 1e-10
FAST_MAX_COND = 1e6  # CholeskyQR2 up to here (safe to ~1e8), the SVD beyond


@dataclass
class Solution:
    """coef (..., p); pinv (..., p, m) maps weighted data to coef, so Cov(coef) = pinv
    diag(noise^2 in weighted units) pinv^T; leverage (..., m) hat-matrix diagonal; rss
    (...,) weighted residual sum of squares; rank (...,); ``blind`` (..., p, p) the projector
    onto the design's null space in the scaled columns (columns / ``scale``): a linear
    functional f of coef is determined by the data iff blind @ (f / scale) = 0.  ``pinv``
    and ``leverage`` are formed from Q (..., m, p) and P (..., p, p) (pinv of the scaled
    columns = P Q^T) when asked for: most solves (Gauss-Newton steps, the noise estimate)
    never need them, nor Q itself, kept as Q^T = M U (U (..., p, m) the first CholeskyQR
    pass's Q^T, M (..., p, p) the second's R^-T)."""

    coef: np.ndarray
    rss: np.ndarray
    rank: np.ndarray
    residual: np.ndarray
    blind: np.ndarray
    scale: np.ndarray
    U: np.ndarray
    M: np.ndarray
    P: np.ndarray
    _pinv: np.ndarray = field(default=None, repr=False)

    @property
    def pinv(self):
        if self._pinv is None:
            self._pinv = ((self.P @ self.M) @ self.U) / self.scale[..., :, None]
        return self._pinv

    @property
    def Q(self):
        return np.swapaxes(self.M @ self.U, -1, -2)

    @property
    def leverage(self):
        return np.einsum("...mk,...mk->...m", self.Q, self.Q)


FIELDS = ("coef", "rss", "rank", "residual", "blind", "scale", "U", "M", "P")


def take(sol, keep):
    """The problems ``keep`` (index or mask of the leading axis) of a ``Solution``."""
    return Solution(**{k: getattr(sol, k)[keep] for k in FIELDS})


def replace(sol, idx, part):
    """``sol`` with its problems ``idx`` replaced by those of ``part`` (a ``Solution`` of
    len(idx) problems); a new ``Solution``, ``sol`` untouched."""
    out = {}
    for k in FIELDS:
        out[k] = getattr(sol, k).copy()
        out[k][idx] = getattr(part, k)
    return Solution(**out)


def merge(parts, n):
    """One ``Solution`` of ``n`` problems from (indices, ``Solution`` of those) parts that
    cover each problem once."""
    out = {}
    for k in FIELDS:
        first = getattr(parts[0][1], k)
        out[k] = np.empty((n,) + first.shape[1:], first.dtype)
        for idx, sol in parts:
            out[k][idx] = getattr(sol, k)
    return Solution(**out)


def solve(A, b, w):
    """Solve every problem of the stack: A (..., m, p), b (..., m), w (..., m).  The work is
    done on A^T (..., p, m), so an A that is a transposed view of a C-ordered (..., p, m)
    stack (``jet_rows.Rows.A``) is used without a copy, and every product is of C-ordered
    stacks."""
    lead, (m, p) = A.shape[:-2], A.shape[-2:]
    At = np.ascontiguousarray(np.swapaxes(A.reshape(-1, m, p), -1, -2))
    b, w = b.reshape(-1, m), w.reshape(-1, m)
    if not np.all(w == 1.0):  # rows removed or weighted (padding); else A is used as is
        At = At * w[:, None, :]
    bw = b * w
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is caught below
        G = At @ np.swapaxes(At, -1, -2)  # A^T A: the column scaling is read off its diagonal
    scale = np.sqrt(np.diagonal(G, axis1=-2, axis2=-1))
    # a problem whose numbers overflowed (a degenerate patch's fit diverging, or |A| past
    # ~1e154, where A^T A does) determines nothing: every column blind, its coefficients
    # NaN; the others of the stack go on
    bad = ~(np.isfinite(scale).all(axis=1) & np.isfinite(bw).all(axis=1))
    if bad.any():
        At = At.copy()  # it may be the caller's array (a view's transpose)
        At[bad], bw[bad], scale[bad], G[bad] = 0.0, 0.0, 0.0, 0.0
    live = scale > 0
    scale = np.where(live, scale, 1.0)
    U, M, P, fast = _cholesky_qr2(At, G / (scale[:, :, None] * scale[:, None, :]), scale, live)
    blind = np.zeros((len(At), p, p))
    blind[:, np.arange(p), np.arange(p)] = ~live
    slow = np.flatnonzero(~fast)
    if slow.size:  # near-singular or rank-deficient: the SVD decides the rank
        Q, P[slow], blind[slow] = _svd(np.swapaxes(At[slow], -1, -2) / scale[slow, None, :])
        U[slow], M[slow] = np.swapaxes(Q, -1, -2), np.eye(p)
    coef = np.einsum("bij,bj->bi", P @ M, (U @ bw[..., None])[..., 0]) / scale  # P Q^T bw
    residual = bw - (coef[:, None, :] @ At)[:, 0]
    coef[bad], residual[bad] = np.nan, np.nan
    out = Solution(
        coef=coef,
        rss=np.einsum("bm,bm->b", residual, residual),
        rank=p - np.rint(np.trace(blind, axis1=-2, axis2=-1)).astype(int),
        residual=residual,
        blind=blind,
        scale=scale,
        U=U,
        M=M,
        P=P,
    )
    for name in FIELDS:
        v = getattr(out, name)
        setattr(out, name, v.reshape(lead + v.shape[1:]))
    return out


def _cholesky_qr2(At, G, scale, live):
    """(U (B, p, m), M (B, p, p), P (B, p, p), ok (B,)): X = A / scale = Q R with
    R = R2 R1, Q^T = M U, so pinv(X) = P Q^T with P = R^-1, where ok; G = X^T X (from A's,
    ``solve``), At = A^T; a zero column (``~live``) stays zero in Q, its coefficient 0.
    X itself is never formed: Q1^T = R1^-T X^T = (R1^-T / scale) A^T."""
    dead = ~live
    R1, ok = _cholesky(_unit_dead(G, dead))
    R1i = _upper_inverse(R1)
    cond = np.sqrt(np.einsum("bij,bij->b", R1, R1) * np.einsum("bij,bij->b", R1i, R1i))
    ok &= cond <= FAST_MAX_COND
    Q1t = (np.swapaxes(R1i, -1, -2) / scale[:, None, :]) @ At
    R2, ok2 = _cholesky(_unit_dead(Q1t @ np.swapaxes(Q1t, -1, -2), dead))
    R2i = _upper_inverse(R2)
    return Q1t, np.swapaxes(R2i, -1, -2), R1i @ R2i, ok & ok2


SMALL_STACK = 32  # fewer problems than this: LAPACK's inverse, one call each


def _upper_inverse(R):
    """R^-1 of every upper-triangular R (B, p, p): by back substitution vectorised over the
    stack (LAPACK's general inverse is one LU per small matrix), or for a stack of fewer
    than ``SMALL_STACK`` by LAPACK (the p steps' Python overhead dominates there).  Both
    are backward stable; they differ at round-off."""
    if len(R) < SMALL_STACK:
        return np.linalg.inv(R)
    p = R.shape[-1]
    Rt = np.ascontiguousarray(np.moveaxis(R, 0, -1))  # (p, p, B): each step's operands
    out = np.zeros_like(Rt)  # are contiguous rows of B, not strided (B, k) slices
    for i in range(p - 1, -1, -1):
        row = out[i]  # (p, B)
        np.einsum("kb,kjb->jb", Rt[i, i + 1 :], out[i + 1 :], out=row)
        np.negative(row, out=row)
        row[i] += 1.0
        row /= Rt[i, i]
    return np.moveaxis(out, -1, 0)


def _unit_dead(G, dead):
    """G (B, p, p) with a unit diagonal on zero columns (their R row is e_k: coefficient 0)."""
    k = np.arange(G.shape[-1])
    G[:, k, k] = np.where(dead, 1.0, G[:, k, k])
    return G


def _cholesky(G):
    """Upper R with R^T R = G per problem, and ok (B,): False where a pivot is not positive
    (R is then the identity, a placeholder the SVD replaces)."""
    B, p, _ = G.shape
    try:  # LAPACK for the whole stack; it refuses the stack if one problem fails
        L = np.linalg.cholesky(G)
    except np.linalg.LinAlgError:  # then one problem at a time: the same as each alone
        L = np.full_like(G, np.nan)
        for b in range(B):
            try:
                L[b] = np.linalg.cholesky(G[b])
            except np.linalg.LinAlgError:
                pass
    R = np.swapaxes(L, -1, -2)
    d = np.diagonal(R, axis1=-2, axis2=-1)
    ok = np.all(d * d > 1e-14 * np.diagonal(G, axis1=-2, axis2=-1), axis=-1)
    R[~ok] = np.eye(p)
    return R, ok


def _svd(X):
    """(U kept (B, m, p), P (B, p, p), blind (B, p, p)) of the SVD path: pinv(X) = P U^T."""
    U, s, Vt = np.linalg.svd(X, full_matrices=False)
    keep = s > RCOND * s[..., :1]
    inv_s = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    Ukeep = U * keep[..., None, :]
    V = np.swapaxes(Vt, -1, -2)
    P = V * inv_s[..., None, :]  # pinv = V diag(1/s) U^T
    Vkeep = V * keep[..., None, :]
    p = X.shape[-1]
    blind = np.eye(p) - Vkeep @ np.swapaxes(Vkeep, -1, -2)
    short = p - s.shape[-1]  # fewer rows than columns: pad to p singular directions
    if short:
        Ukeep = np.concatenate([Ukeep, np.zeros(Ukeep.shape[:-1] + (short,))], axis=-1)
        P = np.concatenate([P, np.zeros(P.shape[:-1] + (short,))], axis=-1)
    return Ukeep, P, blind
