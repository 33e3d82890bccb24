"""The centre jet's least-squares rows, whitened per contact (``centre_jet`` step 2).

Each contact gives three rows, its height z and the slopes z_x, z_y read off its normal
(§4.5.1), whitened by the inverse Cholesky factor of their covariance (errors in
variables; ``make``).  ``geometry`` gives a fit's slopes and second derivatives at the
contacts, from which the next rows are whitened.
"""

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from tactile.ep2 import jet_basis

ORDER = 3  # jet order of both models (cubic terms: free for symmetric layouts, needed otherwise)
GEO_LIMIT = 1e3  # slopes and second derivatives (/ L) beyond this are clipped in the weights


@dataclass
class Rows:
    """One frame's whitened least-squares rows (see ``make``): positions, x-slopes, y-slopes
    stacked (3n rows), or one row type's alone (``part``: n or 2n rows, m below)."""

    x: np.ndarray  # (B, n) contact positions
    y: np.ndarray
    b: np.ndarray  # (B, m) whitened data
    w: np.ndarray  # (B, m) 1 for a used row, 0 for padding
    A: np.ndarray  # (B, m, p) whitened jet design
    T: np.ndarray  # (B, n, 3, 3) each contact's whitening of (z, z_x, z_y) (lower triangular)
    P: np.ndarray  # (B, n, 3, 3) its covariance per unit sigma_p^2 (J J^T)
    N: np.ndarray  # (B, n, 3, 3) ... per unit sigma_n^2
    part: str = "all"  # the row types kept: "all", "pos" or "slopes" (``PARTS``)
    _unit: list = field(default_factory=list, repr=False)  # ``unit``'s, once computed

    def unit(self):
        """(T P T^T, T N T^T) (B, n, 3, 3): each contact's whitened residual covariance per
        unit sigma_p^2 and per unit sigma_n^2 (``jet_covariance.propagate``), computed once
        and shared by the rows of another order (``with_order``) and their sub-stacks
        (``take``)."""
        if not self._unit:
            self._unit.extend(_sandwich(self.T, M) for M in (self.P, self.N))
        return tuple(self._unit)

    def take(self, idx):
        """The patches ``idx`` of the stack (their ``unit`` too, if computed)."""
        unit = [u[idx] for u in self._unit]
        keys = ("x", "y", "b", "w", "A", "T", "P", "N")
        return Rows(*(getattr(self, k)[idx] for k in keys), self.part, unit)

    def whiten(self, v, T=None):
        """Whiten stacked rows (B, 3n) or (B, 3n, k) (positions, x-slopes, y-slopes), keeping
        this ``part``'s rows; ``T`` a subset of the stack's ``T`` (default all of it)."""
        return whiten(v, self.T if T is None else T, self.part)

    def full(self, G):
        """G (..., m) over this part's rows as (..., 3n), zero on the rows left out."""
        if self.part == "all":
            return G
        out = np.zeros(G.shape[:-1] + (3 * self.x.shape[1],))
        out[..., _blocks(self.part, self.x.shape[1])] = G
        return out


PARTS = {"all": (0, 3), "pos": (0, 1), "slopes": (1, 3)}  # row blocks kept: [first, stop)


def _blocks(part, n):
    first, stop = PARTS[part]
    return slice(first * n, stop * n)


def whiten(v, T, part="all"):
    """Each contact's 3 rows times its lower-triangular 3 x 3 whitening (``_inverse_cholesky``;
    six multiply-adds per row: a batched 3 x 3 product is slower through einsum or matmul
    at this size).  ``part`` keeps one row type's blocks (its ``T`` is block diagonal, so
    the rows kept are those of the whole, exactly)."""
    B, n = T.shape[:2]
    blocks = v.reshape(B, 3, n, -1)
    Tt = T[..., None]  # (B, n, 3, 3, 1)
    if part == "pos":
        return (Tt[:, :, 0, 0] * blocks[:, 0]).reshape((B, n) + v.shape[2:])
    first = PARTS[part][0]
    out = np.empty((B, 3 - first) + blocks.shape[2:])
    if part == "all":
        out[:, 0] = Tt[:, :, 0, 0] * blocks[:, 0]
        out[:, 1] = Tt[:, :, 1, 0] * blocks[:, 0] + Tt[:, :, 1, 1] * blocks[:, 1]
        out[:, 2] = Tt[:, :, 2, 0] * blocks[:, 0] + Tt[:, :, 2, 1] * blocks[:, 1]
    else:  # slopes: T[1, 0] = T[2, 0] = 0, so the terms in positions are exact zeros
        out[:, 0] = Tt[:, :, 1, 1] * blocks[:, 1]
        out[:, 1] = Tt[:, :, 2, 1] * blocks[:, 1]
    out[:, -1] += Tt[:, :, 2, 2] * blocks[:, 2]
    return out.reshape((B, (3 - first) * n) + v.shape[2:])


def whitened_design(x, y, order, T, part="all"):
    """``whiten(jet_basis.design(x, y, order), T, part)`` (B, m, p), as the transposed view
    of a C-ordered (B, p, m) stack, the layout ``batch_lstsq.solve`` works in (no copy
    there).  Column x^i y^j / (i! j!) has rows X_i Y_j, X_(i-1) Y_j, X_i Y_(j-1) (X_k =
    x^k / k!, zero for k < 0), so its whitened rows are Y_(j) times a combination of X_i,
    X_(i-1) that depends on i alone, plus T_22 X_i Y_(j-1): formed on the powers (B, order
    + 1, n), then one product per column, not a pass per term over the whole design."""
    B, n = x.shape
    mons = jet_basis.monomials(order)
    first, stop = PARTS[part]
    X, Y = (
        np.stack([np.zeros_like(v)] + jet_basis._scaled_powers(v, order + 1), 1) for v in (x, y)
    )
    t, K = T[:, None, :], stop - first  # (B, 1, n, 3, 3); row blocks kept
    lower, upper = X[:, :-1], X[:, 1:]  # X_(i-1), X_i for i = 0 .. order
    S = np.stack([t[..., k, 0] * upper + t[..., k, 1] * lower for k in range(first, stop)], 2)
    S = S.reshape(B, order + 1, K * n)  # (B, i, rows of the K blocks)
    Yk = Y[:, :, None, :].repeat(K, 2).reshape(B, order + 2, K * n)  # long rows: no broadcast
    W = t[..., 2, 2] * upper  # (B, order + 1, n): T_22 X_i, times Y_(j-1)
    out = np.empty((B, len(mons), K * n))  # A^T
    tmp = np.empty((B, n))
    for c, (i, j) in enumerate(mons):
        np.multiply(S[:, i], Yk[:, j + 1], out=out[:, c])
        if stop == 3 and j > 0:
            out[:, c, -n:] += np.multiply(W[:, i], Y[:, j], out=tmp)
    return np.swapaxes(out, 1, 2)


def make(p, nrm, mask, sig, geo=None, order=None, part="all"):
    """Rows in the current frame, each contact's (z, z_x, z_y) whitened by its covariance.

    Slopes z_x = -nx/nz, z_y = -ny/nz (§4.5.1).  Errors to first order (errors in
    variables, "effective variance"): a position error e (3-D, sigma_p) moves z by
    e_z - g.e_xy and, because the slope is read where the contact is not, the slopes by
    -h e_xy (h the Hessian there); an angular error of the normal (sigma_n) moves the
    slopes with covariance sigma_n^2 (1+|g|^2)(I + g g^T) (checked by simulation in the
    tests).  So Cov = sigma_p^2 J J^T + sigma_n^2 [[0, 0], [0, (1+|g|^2)(I + g g^T)]] with
    J = [[-g^T, 1], [-h, 0]], and the rows are whitened by L^-1, L L^T = Cov.  ``geo`` = (g, h)
    (B, n, 2) and (B, n, 3) from a fit: taken from the observed slopes instead, they favour
    the rows whose noise flattened them and bias the curvature (and h = 0 without a fit).
    ``part`` "pos" or "slopes" keeps one row type (its own marginal covariance), for the
    noise estimate and the positions-versus-normals check.
    """
    nz = np.where(mask, nrm[..., 2], 1.0)
    sx, sy = -nrm[..., 0] / nz * mask, -nrm[..., 1] / nz * mask
    if geo is None:
        g, h = np.stack([sx, sy], -1), np.zeros(mask.shape + (3,))
    else:
        g, h = geo
    T, P, N = _whitening(g, h, sig, part)
    x, y = (np.where(mask, p[..., k], 0.0) for k in (0, 1))
    b = np.concatenate([np.where(mask, p[..., 2], 0.0), sx, sy], axis=1)
    first, stop = PARTS[part]  # the rows a part leaves out are not built at all
    w = np.concatenate([mask] * (stop - first), axis=1).astype(float)
    A = whitened_design(x, y, ORDER if order is None else order, T, part)
    return Rows(x, y, whiten(b, T, part), w, A, T, P, N, part)


def _whitening(g, h, sig, part):
    """(L^-1 with L L^T = Cov, J J^T, N) (B, n, 3, 3) of each contact's (z, z_x, z_y)
    residual: Cov = sigma_p^2 J J^T + sigma_n^2 N (``make``); ``part`` keeps one row type's
    block."""
    g = np.clip(np.nan_to_num(g), -GEO_LIMIT, GEO_LIMIT)  # a degenerate fit's wild geometry
    h = np.clip(np.nan_to_num(h), -GEO_LIMIT, GEO_LIMIT)
    gx, gy = g[..., 0], g[..., 1]
    g2 = gx * gx + gy * gy
    hxx, hxy, hyy = h[..., 0], h[..., 1], h[..., 2]
    # J = [[-gx, -gy, 1], [-hxx, -hxy, 0], [-hxy, -hyy, 0]]: P = J J^T entry by entry (a
    # stack of 3 x 3 products through matmul was a tenth of the rows' cost)
    P = np.empty(gx.shape + (3, 3))
    P[..., 0, 0] = g2 + 1.0
    P[..., 0, 1] = P[..., 1, 0] = gx * hxx + gy * hxy
    P[..., 0, 2] = P[..., 2, 0] = gx * hxy + gy * hyy
    P[..., 1, 1] = hxx * hxx + hxy * hxy
    P[..., 1, 2] = P[..., 2, 1] = hxx * hxy + hxy * hyy
    P[..., 2, 2] = hxy * hxy + hyy * hyy
    N = np.zeros_like(P)
    a = 1.0 + g2
    N[..., 1, 1], N[..., 2, 2] = a * (1.0 + gx * gx), a * (1.0 + gy * gy)
    N[..., 1, 2] = N[..., 2, 1] = a * (gx * gy)
    keep = {"all": [0, 1, 2], "pos": [0], "slopes": [1, 2]}[part]
    drop = [k for k in range(3) if k not in keep]
    if drop:
        for M in (P, N):
            M[..., drop, :] = 0.0
            M[..., :, drop] = 0.0
    cov = sig[:, 0, None, None, None] ** 2 * P
    cov += sig[:, 1, None, None, None] ** 2 * N
    cov[..., drop, drop] = 1.0  # placeholders, removed from T below
    T = _inverse_cholesky(cov)
    T[..., drop, :] = 0.0
    return T, P, N


def _inverse_cholesky(c):
    """L^-1 (lower triangular) with L L^T = c, for every 3 x 3 of the stack, in closed form
    (LAPACK's one call per contact cost a fifth of the fit).  Any whitening W with
    W^T W = c^-1 gives the same fit, covariance and chi^2: they differ by a rotation of
    each contact's three rows."""
    tiny = 1e-300  # a pivot never below this (c is positive definite: sigmas are floored)
    l00 = np.sqrt(np.maximum(c[..., 0, 0], tiny))
    l10, l20 = c[..., 1, 0] / l00, c[..., 2, 0] / l00
    l11 = np.sqrt(np.maximum(c[..., 1, 1] - l10 * l10, tiny))
    l21 = (c[..., 2, 1] - l20 * l10) / l11
    l22 = np.sqrt(np.maximum(c[..., 2, 2] - l20 * l20 - l21 * l21, tiny))
    T = np.zeros_like(c)
    T[..., 0, 0], T[..., 1, 1], T[..., 2, 2] = 1.0 / l00, 1.0 / l11, 1.0 / l22
    T[..., 1, 0] = -l10 * T[..., 0, 0] * T[..., 1, 1]
    T[..., 2, 1] = -l21 * T[..., 1, 1] * T[..., 2, 2]
    T[..., 2, 0] = -(l20 * T[..., 0, 0] + l21 * T[..., 1, 0]) * T[..., 2, 2]
    return T


def _sandwich(T, M):
    """T M T^T for every contact's lower-triangular T and symmetric M (B, n, 3, 3), entry by
    entry (a stack of 3 x 3 products through matmul is one BLAS call per contact)."""
    TM = np.empty_like(M)
    for i in range(3):
        for j in range(3):
            TM[..., i, j] = sum(T[..., i, a] * M[..., a, j] for a in range(i + 1))
    out = np.empty_like(M)
    for i in range(3):
        for k in range(i, 3):
            out[..., i, k] = sum(TM[..., i, a] * T[..., k, a] for a in range(k + 1))
            out[..., k, i] = out[..., i, k]
    return out


def positions(p, mask):
    """The contacts' x, y as ``Rows`` hold them (padding at 0), for ``geometry``."""
    x, y = (np.where(mask, p[..., k], 0.0) for k in (0, 1))
    return SimpleNamespace(x=x, y=y)


def with_order(rows, order):
    """``rows`` with the jet design of another order (same data, weights and whitening)."""
    A = whitened_design(rows.x, rows.y, order, rows.T, rows.part)
    return Rows(rows.x, rows.y, rows.b, rows.w, A, rows.T, rows.P, rows.N, rows.part, rows._unit)


def geometry(rows, coef, model=None):
    """(g (B, n, 2), h (B, n, 3)): slopes and second derivatives of a fit at the contacts
    (``rows`` or ``positions``: their x, y); ``model`` (B,) 1 where ``coef`` is the round
    model (its closed-form part added)."""
    x, y = rows.x, rows.y
    v = _jet_derivatives(x, y, coef, ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2)))
    if model is not None and np.any(model == 1):
        H = jet_basis.hessian(coef)
        _, ex, ey = jet_basis.round_excess(x, y, H)
        exx, exy, eyy = jet_basis.round_second(x, y, H)
        extra = np.stack([ex, ey, exx, exy, eyy], axis=1)
        v = v + np.where(model[:, None, None] == 1, extra, 0.0)
    return np.moveaxis(v[:, :2], 1, -1), np.moveaxis(v[:, 2:], 1, -1)


def _jet_derivatives(x, y, coef, derivs):
    """(B, len(derivs), n): the jet's derivatives (dx, dy) at the contacts, as sum_i
    X_(i-dx) (C Y_(.-dy))_i with C[i, j] the coefficient of x^i y^j / (i! j!) (X_k =
    x^k / k!, zero for k < 0): products on the powers, not a design of 5 n rows."""
    B, n = x.shape
    order = jet_basis.order_of(coef.shape[-1])
    q, top = order + 1, max(max(d) for d in derivs)
    C = np.zeros((B, q, q))
    i, j = (np.array([e[k] for e in jet_basis.monomials(order)]) for k in (0, 1))
    C[:, i, j] = coef
    X, Y = (
        np.concatenate([np.zeros((B, top, n)), np.stack(jet_basis._scaled_powers(v, q), 1)], 1)
        for v in (x, y)
    )  # index k + top: v^k / k!
    Z = {dy: C @ Y[:, top - dy : top - dy + q] for dy in {d[1] for d in derivs}}
    return np.stack(
        [np.einsum("bin,bin->bn", X[:, top - dx : top - dx + q], Z[dy]) for dx, dy in derivs], 1
    )
