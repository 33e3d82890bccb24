"""The centre jet's noise estimate (``centre_jet`` step 2): sigma_p and sigma_n by REML.

Each sigma the user does not state is estimated from its own row type's jet fit
(positions alone, slopes alone), as chi^2 over the spare rows (rows minus the rank, which
is the sum of the leverages).
"""

import numpy as np

from tactile.ep2 import batch_lstsq, jet_basis, jet_models, jet_rows

NOISE_ORDER = 5  # jet order for the noise estimate (least model bias), lower for few contacts
WEIGHT_FLOOR = 1e-6  # relative noise floor for the weights: round-off on exact data sits below
NOISE_PASSES = 3  # fixed-point passes for sigma_n (its covariance holds sigma_p too)


def estimate(p, nrm, mask, noise_pos, noise_normal, L):
    """(sigma_p / L, sigma_n) and their degrees of freedom (inf: stated) per patch.

    A sigma not stated is estimated by REML from its own rows: positions from a jet of
    positions, slopes from a jet of slopes (``_noise_order``; geometry from a first fit).
    Estimated jointly, a disagreement between positions and normals would inflate both
    and hide.  The slopes' covariance holds sigma_p too (``jet_rows.make``), so sigma_n is found
    by a few fixed-point passes on the slopes' chi^2 per spare row.
    """
    B = len(mask)
    sig, dof = np.ones((B, 2)), np.full((B, 2), np.inf)
    if noise_pos is not None:
        sig[:, 0] = max(float(noise_pos), 0.0) / L
    if noise_normal is not None:
        sig[:, 1] = max(float(noise_normal), 0.0)
    sig = np.maximum(sig, WEIGHT_FLOOR)
    if noise_pos is not None and noise_normal is not None:
        return sig, dof
    rows = jet_rows.make(p, nrm, mask, sig)
    geo = jet_rows.geometry(rows, jet_models.quadric(rows).sol.coef)
    n = mask.sum(axis=1)
    if noise_pos is None:
        sig[:, 0], dof[:, 0] = _reml(p, nrm, mask, sig, geo, "pos", n)
    if noise_normal is None:
        ratio = _slope_share(geo, mask)
        for _ in range(NOISE_PASSES):
            scale, dof[:, 1] = _reml(p, nrm, mask, sig, geo, "slopes", 2 * n)
            # chi^2 per spare row = scale^2: the slopes' covariance sigma_p^2 h h^T +
            # sigma_n^2 S is scale^2 times too small; sigma_n takes all of the change
            var = scale**2 * sig[:, 1] ** 2 + (scale**2 - 1.0) * sig[:, 0] ** 2 * ratio
            sig[:, 1] = np.sqrt(np.maximum(var, WEIGHT_FLOOR**2))
    return np.maximum(sig, WEIGHT_FLOOR), dof


def _slope_share(geo, mask):
    """Mean over the contacts of tr(h h^T) / tr(S): the slopes' variance from position noise
    per unit sigma_p^2 over the one from normal noise per unit sigma_n^2 (``jet_rows.make``)."""
    g, h = geo
    g2 = np.sum(g * g, axis=-1)
    tr_s = (1.0 + g2) * (2.0 + g2)
    tr_h = h[..., 0] ** 2 + 2 * h[..., 1] ** 2 + h[..., 2] ** 2
    return np.sum(np.where(mask, tr_h / tr_s, 0.0), axis=1) / np.maximum(mask.sum(axis=1), 1)


def _reml(p, nrm, mask, sig, geo, part, count):
    """(sqrt(chi^2 / spare rows), spare rows) of one row type's own jet fit.  For positions
    the rows are whitened with sigma_p = 1, so the first value IS sigma_p / L."""
    trial = sig.copy()
    if part == "pos":
        trial[:, 0] = 1.0
    rows = jet_rows.make(p, nrm, mask, trial, geo, NOISE_ORDER, part)
    degree = np.array([i + j for i, j in jet_basis.monomials(NOISE_ORDER)])
    order = _noise_order(count)
    sol = batch_lstsq.solve(rows.A * (degree <= order[:, None])[:, None, :], rows.b, rows.w)
    spare = count - sol.rank  # the leverages sum to the rank: no hat matrix needed
    ok = spare >= 1.0  # no spare rows: the noise is unknown, taken as large (sigma 1 = L)
    value = np.where(ok, np.sqrt(sol.rss / np.where(ok, spare, 1.0)), 1.0)
    return value, np.where(ok, spare, 1.0)


def _noise_order(rows):
    """Highest jet order (<= NOISE_ORDER, >= 2) leaving at least half of ``rows`` spare."""
    order = np.full(np.shape(rows), 2)
    for q in range(3, NOISE_ORDER + 1):
        order = np.where(jet_basis.n_coef(q) <= rows / 2, q, order)
    return order
