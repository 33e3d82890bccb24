"""Empirical-Bayes shrinkage of a tensor-product patch toward its 2-jet (beyond the thesis).

A degree (kx, ky) patch spans the monomials u^i v^j, i <= kx, j <= ky.  Only
the six of total degree <= 2 (the quadric, or 2-jet) are needed for a
surface of constant curvature to second order; the others (u^2 v, u v^2,
u^2 v^2, ... the *excess*) carry the fourth-order shape but, with 36 noisy
contacts on three finger lines, mostly fit noise.  The excess is shrunk toward
zero by the positive-part empirical-Bayes factor (James-Stein type, g-prior
with its scale estimated by the method of moments)

    w = max(0, 1 - q / d^2),   d^2 = (chi^2_jet - chi^2_full) / s^2,

q the number of excess terms, d^2 the Wald statistic of the excess (chi^2_q
when the excess is zero) and s^2 the fit's variance factor.  The result is
c = c_jet + w (c_full - c_jet), with c_jet the least-squares fit constrained to
the 2-jet span.  Clean data (d^2 >> q) keep the full patch (w -> 1); noisy
data approach the quadric.

Everything uses the full fit's precision factor R = F^-1 (R^T R = A^T A, F the
covariance factor), so the weighted rows are not revisited.  With w held fixed,
nested least squares give Cov(c_jet, c_full) = Cov(c_jet), hence
Cov(c) = (1 - w^2) Cov(c_jet) + w^2 Cov(c_full).
"""

import dataclasses
from functools import lru_cache

import numpy as np

from tactile.ep2 import bspline_patch


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
    rows = bspline_patch.rowwise_kron(
        bspline_patch.basis(uu, kx, tx), bspline_patch.basis(vv, ky, ty)
    )
    mono = np.column_stack([np.ones_like(uu), uu, vv, uu * uu, uu * vv, vv * vv])
    return np.linalg.lstsq(rows, mono, rcond=None)[0]


def shrink(fit, z, sx, sy, s2, rows):
    """Shrink ``fit`` (a ``SplineFit``) toward its 2-jet.  Returns (fit, w, d2).

    ``z, sx, sy`` are the data the fit was made from and ``rows`` its
    unweighted design rows (``bspline_patch.prepare``), for the residuals;
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
