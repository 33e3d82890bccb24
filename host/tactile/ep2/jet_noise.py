"""The centre jet's noise estimate (``centre_jet`` step 2): sigma_p and sigma_n by REML.

Each sigma the user does not state is estimated from its own row type's jet fit
(positions alone, slopes alone), as chi^2 over the spare rows (rows minus the rank, which
is the sum of the leverages).
"""

import numpy as np

from tactile.ep2 import batch_lstsq, jet_basis, jet_models, jet_rows

NOISE_ORDER = 5  # jet order for the noise estimate (least model bias), lower for few contacts
WEIGHT_FLOOR = 1e-6  # relative noise floor for the weights: round-off on exact data sits below
NOISE_TOL = 1e-3  # sigma_n to this relative change (its own sampling error is ~10 %)
NOISE_PASSES = 12  # REML passes for sigma_n at most (3 for most patches; see _normal_noise)


def estimate(p, nrm, mask, noise_pos, noise_normal, L):
    """(sigma_p / L, sigma_n) and their degrees of freedom (inf: stated) per patch.

    A sigma not stated is estimated by REML from its own rows: positions from a jet of
    positions, slopes from a jet of slopes (``_noise_order``; geometry from a first fit).
    Estimated jointly, a disagreement between positions and normals would inflate both
    and hide.  The slopes' covariance holds sigma_p too (``jet_rows.make``), so sigma_n is the
    root of the slopes' chi^2 per spare row = 1 (``_normal_noise``).
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
        sig[:, 1], dof[:, 1] = _normal_noise(p, nrm, mask, sig, geo, 2 * n)
    return np.maximum(sig, WEIGHT_FLOOR), dof


def _normal_noise(p, nrm, mask, sig, geo, count):
    """(sigma_n, its degrees of freedom) per patch: the root of chi^2 / spare = 1 for the
    slopes' own jet fit, chi^2 falling as sigma_n grows (the covariance grows).  Each pass
    takes the fixed-point step (``_fixed_point``) while it stays inside the bracket the
    passes so far have found, else false position on log chi^2 against log sigma_n between
    the bracket's ends; a patch leaves once sigma_n moves less than ``NOISE_TOL``, so it
    gets the passes it would get alone.  The fixed point alone could cycle where position
    noise dominates the slopes' covariance (sigma_n 0 <-> 0.19 rad for 0.0005 true, on a
    cylinder with 1 % position noise): it then depended on the number of passes."""
    B = len(mask)
    ratio = _slope_share(geo, mask)
    sn, dof = sig[:, 1].copy(), np.ones(B)
    lo, hi = np.full((B, 2), [0.0, np.nan]), np.full((B, 2), [np.inf, np.nan])  # (sigma, log s^2)
    todo = np.arange(B)
    for _ in range(NOISE_PASSES):
        trial = np.stack([sig[todo, 0], sn[todo]], axis=1)
        sub = (geo[0][todo], geo[1][todo])
        scale, dof[todo] = _reml(p[todo], nrm[todo], mask[todo], trial, sub, "slopes", count[todo])
        cur, phi = sn[todo], 2.0 * np.log(np.maximum(scale, 1e-300))
        # chi^2 per spare row scale^2 falls as sigma_n grows: the root is above cur if > 1
        up = scale >= 1.0
        lo[todo] = np.where(
            up[:, None] & (cur >= lo[todo, 0])[:, None], np.stack([cur, phi], 1), lo[todo]
        )
        dn = ~up
        hi[todo] = np.where(
            dn[:, None] & (cur <= hi[todo, 0])[:, None], np.stack([cur, phi], 1), hi[todo]
        )
        new = _fixed_point(scale, cur, sig[todo, 0], ratio[todo])
        new = np.where(
            (new > lo[todo, 0]) & (new < hi[todo, 0]), new, _false_position(lo[todo], hi[todo])
        )
        floor = (new <= WEIGHT_FLOOR) & (cur <= WEIGHT_FLOOR)  # the root is below the floor
        done = (np.abs(new - cur) <= NOISE_TOL * cur) | floor | ~np.isfinite(scale)
        sn[todo] = np.maximum(new, WEIGHT_FLOOR)
        todo = todo[~done]
        if not todo.size:
            break
    return sn, dof


def _fixed_point(scale, cur, sig_p, ratio):
    """The next sigma_n if chi^2 scaled as 1 / (mean slope variance): the slopes' covariance
    sigma_p^2 h h^T + sigma_n^2 S is scale^2 times too small, and sigma_n takes all of the
    change (floored at ``WEIGHT_FLOOR``)."""
    var = scale**2 * cur**2 + (scale**2 - 1.0) * sig_p**2 * ratio
    return np.sqrt(np.maximum(var, WEIGHT_FLOOR**2))


def _false_position(lo, hi):
    """A sigma_n strictly inside the bracket (lo, hi) ((B, 2): sigma, log chi^2 per spare row
    there): false position on log sigma where both ends are known, the floor where no pass
    has been below the root yet, ten times up where none has been above it."""
    a, b = np.log(np.maximum(lo[:, 0], WEIGHT_FLOOR)), np.log(np.minimum(hi[:, 0], 1e300))
    fa, fb = lo[:, 1], hi[:, 1]
    t = np.clip(fa / np.where(fa - fb > 0, fa - fb, np.nan), 0.1, 0.9)  # keep off the ends
    out = np.exp(a + np.nan_to_num(t, nan=0.5) * (b - a))
    out = np.where(lo[:, 0] > 0, out, WEIGHT_FLOOR)
    return np.where(np.isfinite(hi[:, 0]), out, 10.0 * lo[:, 0])


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
