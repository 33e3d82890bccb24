"""The thesis's method (``method="spline"``): a tensor-product B-spline patch z = S(x, y)
fitted to positions and slopes (§4.6, eqs. 52-58), and its analysis.

Kept to reproduce chapters 4-5 (``--order 3 --weighting tangent`` is the thesis's bicubic
at 100:1, §4.9), not the default: on the held-out grid the centre jet (``local_jet``) is
more accurate.  SciPy loads with this module, so only the spline imports it.

**Fit** (``fit_patch``).  Basis functions and their derivatives come from
``scipy.interpolate.BSpline`` (the thesis's eqs. 55, 59 and 73 contain typos: eq. 55
repeats N (x) M for the y-tangent rows and eq. 59 gives S_xx a first-derivative factor).
Here the rows are, with (.) the row-wise Kronecker product:

    position rows  N  (.) M      slope-x rows  N' (.) M      slope-y rows  N (.) M'

Coordinates are normalised to u = (x - x0)/hx in [0, 1] before evaluating the basis, so
everything that depends only on degree and knots is cached.  The weighted system is
column-scaled and solved by SVD (or QR / LAPACK gelsy): never the normal equations of
eq. 57.  A rank-deficient system raises ``DataError`` saying why.

**Shrinkage** (``shrink_to_jet``): the tensor-product excess shrunk toward the 2-jet.
The analysis of a patch with it (weights, alignment, the centre, intervals, labels) is
``spline_answers``.
"""

import dataclasses
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.interpolate import BSpline

from tactile.errors import DataError

ONE_LINE = "all contacts on one line (a single finger?): the patch needs contacts in two directions"
RCOND = 1e-10  # smallest accepted singular value relative to the largest (column-scaled)


@lru_cache(maxsize=256)
def knots(degree, segments=1, breaks=None):
    """Clamped knot vector on [0, 1] (a tuple): uniform interior knots, or ``breaks``.

    A break repeated ``degree`` times makes the patch C0 there (a crease, §6.2.5).
    """
    inner = np.linspace(0.0, 1.0, segments + 1)[1:-1] if breaks is None else np.sort(breaks)
    return tuple(np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)]).tolist())


@lru_cache(maxsize=64)
def _spline(degree, t):
    n = len(t) - degree - 1
    return BSpline(np.array(t), np.eye(n), degree, extrapolate=True)


@lru_cache(maxsize=64)
def _power_table(degree, t):
    """Power-basis coefficients P ((k+1) x n) of a single-segment basis: B(u) = [1 u .. u^k] P.

    Taken from ``scipy.interpolate.BSpline`` by exact interpolation at k + 1
    Chebyshev nodes (the basis functions are polynomials of degree k on [0, 1]).
    """
    nodes = 0.5 - 0.5 * np.cos(np.pi * (np.arange(degree + 1) + 0.5) / (degree + 1))
    vander = np.vander(nodes, degree + 1, increasing=True)
    return np.linalg.solve(vander, _spline(degree, t)(nodes))


def basis(u, degree, t, nu=0):
    """Rows of all basis functions (or their nu-th derivative) at u (normalised)."""
    return bases(u, degree, t, nu)[nu]


def bases(u, degree, t, nu_max=2):
    """[B, B', ..., B^(nu_max)] rows at u (normalised); ``t`` a knot tuple from ``knots``.

    A single segment uses the cached power-basis table (one small product per
    derivative order); more segments call ``BSpline`` directly.
    """
    u = np.asarray(u, float)
    if len(t) != 2 * (degree + 1):
        spline = _spline(degree, t)
        return [spline(u, nu) for nu in range(nu_max + 1)]
    table = _power_table(degree, t)
    powers = u[:, None] ** np.arange(degree + 1)
    out = []
    for nu in range(nu_max + 1):
        if nu > degree:
            out.append(np.zeros((u.size, table.shape[1])))
            continue
        j = np.arange(nu, degree + 1)
        fact = np.prod([j - i for i in range(nu)], axis=0) if nu else 1.0
        out.append((powers[:, : degree + 1 - nu] * fact) @ table[nu:])
    return out


def rowwise_kron(a, b):
    """Row-wise Kronecker product (the tensor-product rows of eq. 53)."""
    return (a[:, :, None] * b[:, None, :]).reshape(a.shape[0], -1)


@dataclass(frozen=True)
class Domain:
    """Affine map from patch-frame (x, y) to the unit square of the spline."""

    x0: float
    y0: float
    hx: float
    hy: float

    @classmethod
    def around(cls, x, y):
        hx = float(np.ptp(x))
        hy = float(np.ptp(y))
        return cls(float(np.min(x)), float(np.min(y)), hx, hy)

    def to_unit(self, x, y):
        return (np.asarray(x) - self.x0) / self.hx, (np.asarray(y) - self.y0) / self.hy


@dataclass(frozen=True)
class SplineFit:
    """A fitted patch: coefficients, their covariance factor and the fit's residual scale.

    ``cov_factor`` (p, r) satisfies Cov(coef) = cov_factor @ cov_factor.T for
    unit-variance weighted rows; ``leverage`` is the diagonal of the hat matrix
    per row (z rows, then slope-x, then slope-y; 0 for a dropped row), and
    ``data_map`` the linear map from those data to ``coef`` (the fit of other
    data at the same points and weights, e.g. for a model-bias estimate).
    """

    degree: tuple
    tx: tuple
    ty: tuple
    domain: Domain
    coef: np.ndarray
    cov_factor: np.ndarray
    chi2: float
    dof: int
    rank: int
    cond: float
    residuals: tuple  # unweighted (z, slope-x, slope-y) residuals at the contacts
    leverage: np.ndarray = None
    data_map: np.ndarray = None  # (p, 3 n): coef = data_map @ [z, slope-x, slope-y]

    def rows(self, x, y, first=0):
        """Stacked design rows of (z, zx, zy, zxx, zxy, zyy)[first:] at patch-frame points."""
        u, v = self.domain.to_unit(x, y)
        kx, ky = self.degree
        bx = [b / self.domain.hx**nu for nu, b in enumerate(bases(u, kx, self.tx, 2))]
        by = [b / self.domain.hy**nu for nu, b in enumerate(bases(v, ky, self.ty, 2))]
        pairs = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))[first:]
        return np.vstack([rowwise_kron(bx[i], by[j]) for i, j in pairs])

    def grid_rows(self, xs, ys, first=0):
        """``rows`` at the tensor grid xs x ys (x index slowest, as meshgrid 'ij' raveled).

        Evaluates the basis on the len(xs) + len(ys) grid lines only.
        """
        u, v = self.domain.to_unit(xs, ys)
        kx, ky = self.degree
        bx = [b / self.domain.hx**nu for nu, b in enumerate(bases(u, kx, self.tx, 2))]
        by = [b / self.domain.hy**nu for nu, b in enumerate(bases(v, ky, self.ty, 2))]
        pairs = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))[first:]
        n = len(xs) * len(ys)
        blocks = [
            (bx[i][:, None, :, None] * by[j][None, :, None, :]).reshape(n, -1) for i, j in pairs
        ]
        return np.vstack(blocks)

    def derivatives(self, x, y, coef=None, first=0):
        """(z, zx, zy, zxx, zxy, zyy)[first:] at points; ``coef`` may be (p, m) for m surfaces."""
        c = self.coef if coef is None else coef
        n = np.size(x)
        out = self.rows(x, y, first) @ c
        return tuple(out[i * n : (i + 1) * n] for i in range(6 - first))


def design(x, y, domain, degree, tx, ty):
    """Position, slope-x and slope-y rows (unweighted) at the data points."""
    u, v = domain.to_unit(x, y)
    kx, ky = degree
    nx0, nx1 = bases(u, kx, tx, 1)
    my0, my1 = bases(v, ky, ty, 1)
    nx1 = nx1 / domain.hx
    my1 = my1 / domain.hy
    return rowwise_kron(nx0, my0), rowwise_kron(nx1, my0), rowwise_kron(nx0, my1)


def prepare(x, y, degree=(2, 2), segments=(1, 1)):
    """Domain and unweighted design rows for ``fit_patch(..., domain=, rows=)`` (reweighting)."""
    degree = (int(degree[0]), int(degree[1]))
    domain = Domain.around(x, y)
    _check_spread(x, y, domain)
    tx = knots(degree[0], segments[0])
    ty = knots(degree[1], segments[1])
    return domain, design(x, y, domain, degree, tx, ty)


def fit_patch(
    x,
    y,
    z,
    sx,
    sy,
    w_pos,
    w_sx,
    w_sy,
    degree=(2, 2),
    segments=(1, 1),
    solver="svd",
    domain=None,
    rows=None,
):
    """Weighted least-squares patch (eq. 56) to positions z and slopes sx, sy.

    Weights multiply rows (1/sigma of each row's noise gives the
    maximum-likelihood fit); a weight of 0 drops the row.  ``rows`` may pass
    the unweighted ``design`` rows of an earlier fit to the same points
    (reweighting passes), with that fit's ``domain``.
    """
    degree = (int(degree[0]), int(degree[1]))
    tx = knots(degree[0], segments[0])
    ty = knots(degree[1], segments[1])
    domain = Domain.around(x, y) if domain is None else domain
    _check_spread(x, y, domain)
    a0, a1, a2 = design(x, y, domain, degree, tx, ty) if rows is None else rows
    w = np.concatenate([np.broadcast_to(w, np.shape(x)) for w in (w_pos, w_sx, w_sy)])
    A = np.vstack([a0, a1, a2]) * w[:, None]
    rhs = np.concatenate([z, sx, sy]) * w
    keep = w > 0
    A, rhs = A[keep], rhs[keep]
    coef, factor, rank, cond, resid, lev = solve(A, rhs, solver)
    if rank < A.shape[1]:
        raise DataError(_why_rank_deficient(x, y, degree, segments, A.shape[1], rank))
    dof = A.shape[0] - A.shape[1]
    res = (z - a0 @ coef, sx - a1 @ coef, sy - a2 @ coef)
    leverage = np.zeros(w.size)
    leverage[keep] = lev
    data_map = np.zeros((coef.size, w.size))
    data_map[:, keep] = ((factor @ factor.T) @ A.T) * w[keep]
    return SplineFit(
        degree, tx, ty, domain, coef, factor, float(resid), dof, rank, cond, res, leverage, data_map
    )


def solve(A, b, solver="svd"):
    """Column-scaled least squares.  Returns coef, covariance factor, rank, cond, RSS, leverage.

    Cov(coef) = F F^T for unit-variance rows (``F = D^-1 V S^-1``); leverage is
    the hat-matrix diagonal (squared row norms of the orthonormal factor).
    """
    scale = np.sqrt(np.einsum("ij,ij->j", A, A))
    scale[scale == 0] = 1.0
    As = A / scale
    if solver == "svd":
        U, s, Vt = np.linalg.svd(As, full_matrices=False)
        rank = int(np.sum(s > RCOND * s[0])) if s.size else 0
        cond = float(s[0] / s[-1]) if s[-1] > 0 else np.inf
        if rank < As.shape[1]:
            return None, None, rank, cond, np.inf, None
        y = (U.T @ b) / s
        coef_s = Vt.T @ y
        factor = Vt.T / s
        lev = np.einsum("ij,ij->i", U, U)
    elif solver == "qr":
        from scipy.linalg import qr, solve_triangular

        Q, R = qr(As, mode="economic", check_finite=False)
        d = np.abs(np.diag(R))
        rank = int(np.sum(d > RCOND * d.max())) if d.size else 0
        cond = float(d.max() / d.min()) if d.min() > 0 else np.inf
        if rank < As.shape[1]:
            return None, None, rank, cond, np.inf, None
        coef_s = solve_triangular(R, Q.T @ b, check_finite=False)
        factor = solve_triangular(R, np.eye(R.shape[0]), check_finite=False)
        lev = np.einsum("ij,ij->i", Q, Q)
    elif solver == "gelsy":
        from scipy.linalg import lstsq

        coef_s, _, rank, _ = lstsq(As, b, cond=RCOND, lapack_driver="gelsy", check_finite=False)
        if rank < As.shape[1]:
            return None, None, rank, np.inf, np.inf, None
        R = np.linalg.qr(As, mode="r")
        factor = np.linalg.inv(R)
        cond = float(np.linalg.cond(R))
        Af = As @ factor
        lev = np.einsum("ij,ij->i", Af, Af)
    else:
        raise ValueError(f"unknown solver {solver!r} (svd, qr, gelsy)")
    r = b - As @ coef_s
    return coef_s / scale, factor / scale[:, None], rank, cond, float(r @ r), lev


def _check_spread(x, y, domain):
    if not (domain.hx > 0 and domain.hy > 0):
        raise DataError(ONE_LINE)


def _why_rank_deficient(x, y, degree, segments, p, rank):
    pts = np.column_stack([x, y])
    pts = pts - pts.mean(axis=0)
    sv = np.linalg.svd(pts, compute_uv=False)
    if sv[1] <= 1e-9 * max(sv[0], 1e-300):
        return ONE_LINE
    ux = np.unique(np.round(np.asarray(x) / (np.ptp(x) or 1.0), 9)).size
    uy = np.unique(np.round(np.asarray(y) / (np.ptp(y) or 1.0), 9)).size
    return (
        f"too few points for degree {degree[0]}x{degree[1]}"
        f" with {segments[0]}x{segments[1]} segment(s):"
        f" {p} coefficients but the rows determine only {rank}"
        f" ({len(x)} contacts, {ux} distinct x and {uy} distinct y); lower --order or add contacts"
    )


# --- Empirical-Bayes shrinkage of a tensor-product patch toward its 2-jet (beyond the thesis).
#
# A degree (kx, ky) patch spans the monomials u^i v^j, i <= kx, j <= ky. Only the six of total
# degree <= 2 (the quadric, or 2-jet) are needed for a surface of constant curvature to second
# order; the others (u^2 v, u v^2, u^2 v^2, ... the *excess*) carry the fourth-order shape but,
# with 36 noisy contacts on three finger lines, mostly fit noise. The excess is shrunk toward zero
# by the positive-part empirical-Bayes factor (James-Stein type, g-prior with its scale estimated
# by the method of moments)
#
# w = max(0, 1 - q / d^2), d^2 = (chi^2_jet - chi^2_full) / s^2,
#
# q the number of excess terms, d^2 the Wald statistic of the excess (chi^2_q when the excess is
# zero) and s^2 the fit's variance factor. The result is c = c_jet + w (c_full - c_jet), with
# c_jet the least-squares fit constrained to the 2-jet span. Clean data (d^2 >> q) keep the full
# patch (w -> 1); noisy data approach the quadric.
#
# Everything uses the full fit's precision factor R = F^-1 (R^T R = A^T A, F the covariance
# factor), so the weighted rows are not revisited. With w held fixed, nested least squares give
# Cov(c_jet, c_full) = Cov(c_jet), hence Cov(c) = (1 - w^2) Cov(c_jet) + w^2 Cov(c_full).


@lru_cache(maxsize=64)
def jet_span(kx, ky, tx, ty):
    """(p, 6) spline coefficients of 1, u, v, u^2, u v, v^2 on the unit square.

    Exact: every polynomial of degree <= k per direction lies in the spline
    space, so interpolation on a fine enough tensor grid recovers it.
    """
    nx, ny = len(tx) - kx - 1, len(ty) - ky - 1
    u = np.linspace(0.0, 1.0, nx + 2)
    v = np.linspace(0.0, 1.0, ny + 2)
    uu, vv = (g.ravel() for g in np.meshgrid(u, v, indexing="ij"))
    rows = rowwise_kron(basis(uu, kx, tx), basis(vv, ky, ty))
    mono = np.column_stack([np.ones_like(uu), uu, vv, uu * uu, uu * vv, vv * vv])
    return np.linalg.lstsq(rows, mono, rcond=None)[0]


def shrink_to_jet(fit, z, sx, sy, s2, rows):
    """Shrink ``fit`` (a ``SplineFit``) toward its 2-jet.  Returns (fit, w, d2).

    ``z, sx, sy`` are the data the fit was made from and ``rows`` its
    unweighted design rows (``prepare``), for the residuals;
    ``s2`` the variance factor of the weighted rows (chi^2/dof, or 1 with the
    noise stated).  Patches with no excess (degree < 2, or exactly a 2-jet)
    come back unchanged with w = 1.
    """
    kx, ky = fit.degree
    p = fit.coef.size
    q = p - 6
    if min(kx, ky) < 2 or q <= 0:
        return fit, 1.0, np.inf
    Q = jet_span(kx, ky, fit.tx, fit.ty)
    R = np.linalg.inv(fit.cov_factor)
    U, s, Vt = np.linalg.svd(R @ Q, full_matrices=False)
    beta = Vt.T @ ((U.T @ (R @ fit.coef)) / s)
    c_jet = Q @ beta
    delta = float(np.sum(np.square(R @ (c_jet - fit.coef))))  # chi^2_jet - chi^2_full
    if not delta > 0:
        return fit, 1.0, np.inf
    d2 = delta / s2 if s2 > 0 else np.inf
    w = max(0.0, 1.0 - q / d2)
    coef = c_jet + w * (fit.coef - c_jet)
    f_jet = Q @ (Vt.T / s)
    # the same shrinkage as a linear map of the full coefficients: c = ((1 - w) P + w I) c_full
    proj = f_jet @ (U.T @ R)
    shrink_map = (1.0 - w) * proj + w * np.eye(p)
    factor = np.hstack([np.sqrt(1.0 - w * w) * f_jet, w * fit.cov_factor])
    a0, a1, a2 = rows
    res = (z - a0 @ coef, sx - a1 @ coef, sy - a2 @ coef)
    chi2 = fit.chi2 + (1.0 - w) ** 2 * delta
    data_map = None if fit.data_map is None else shrink_map @ fit.data_map
    out = dataclasses.replace(
        fit, coef=coef, cov_factor=factor, chi2=chi2, residuals=res, data_map=data_map
    )
    return out, w, d2
