"""Curvature at the patch centre and its covariance (``centre_jet`` step 5).

``tensor``: the shape-operator entries t = (a, b, c) of a jet and their linear map from
the whitened data (complex step).  ``propagate``: Cov of any such linear map, each
contact's noise lifted to at least ``FLOOR``, with its Satterthwaite degrees of freedom.
"""

import numpy as np

from tactile.ep2 import jet_basis
from tactile.ep2.surface_geometry import shape_entries

FLOOR = 1e-3  # noise floor for Cov: positions / L and normals (rad)


def tensor(coef, pinv):
    """t (B, 3) at the origin and dt / d(weighted data) (B, 3, m), by complex step."""
    ch = coef[:, list(jet_basis.CHANNELS)]
    steps = ch[:, None, :] + 1j * 1e-20 * np.eye(5)[None]  # (B, 5 copies, 5 channels)
    # a patch its contacts do not determine (one line) can carry astronomically large
    # coefficients, whose squares leave the float range: ``centre_result.determination``
    # refuses it from its spread and covariance; the other patches of the batch are exact
    with np.errstate(over="ignore", invalid="ignore"):
        a, b, c = shape_entries(*np.moveaxis(steps, -1, 0))
    t = np.stack([a[:, 0].real, b[:, 0].real, c[:, 0].real], axis=1)
    J = np.stack([a.imag, b.imag, c.imag], axis=1) / 1e-20  # (B, 3, 5)
    return t, J @ pinv[:, list(jet_basis.CHANNELS), :]


def propagate(G, rows, rss, rank, sig, dof):
    """Cov = s^2 sum_c G_c T_c Sigma_c T_c^T G_c^T over the contacts c (G: (B, q, m), a linear
    map of the whitened data ``rows``), where Sigma_c is the contact's covariance with each sigma
    lifted to at least ``FLOOR``, and s^2 = max(chi^2/dof, 1); and the Satterthwaite degrees
    of freedom of that noise estimate."""
    G = rows.full(G)  # one row type's rows: zeros for the others
    B, q, m3 = G.shape
    n = m3 // 3
    Gc = G.reshape(B, q, 3, n)
    lifted = np.maximum(sig, FLOOR)
    # each row type's part for a unit sigma
    unit = [np.einsum("zian,znac,zjcn->zij", Gc, K, Gc) for K in rows.unit()]
    parts = [lifted[:, k, None, None] ** 2 * unit[k] for k in range(2)]
    used = rows.w.sum(axis=1)
    s2 = np.maximum(rss / np.maximum(used - rank, 1), 1.0)
    with np.errstate(invalid="ignore"):  # inf x 0 on a failed round fit, which is not used
        cov = s2[:, None, None] * (parts[0] + parts[1])
        # the noise as estimated, no floor: what the estimate's own scatter is (debiasing)
        raw = s2[:, None, None] * sum(sig[:, k, None, None] ** 2 * unit[k] for k in range(2))
    share = np.stack([np.trace(q_, axis1=1, axis2=2) for q_ in parts], axis=1)
    with np.errstate(invalid="ignore"):  # inf / inf on a failed round fit, which is not used
        share = share / np.maximum(share.sum(axis=1, keepdims=True), 1e-300)
    share = np.nan_to_num(share, nan=0.5)
    known = np.where(lifted > sig, np.inf, dof)  # at the floor, the noise is taken as known
    denom = np.sum(share**2 / known, axis=1)
    nu = np.where(denom > 0, 1.0 / np.where(denom > 0, denom, 1.0), np.inf)
    return cov, nu, raw
