"""Uncertainty of the fitted patch: coefficient covariance propagated by Monte Carlo.

The least-squares solution has Cov(c) = s^2 F F^T (``SplineFit.cov_factor``),
with s^2 the residual variance factor chi^2/dof (or 1 when the stated sensor
noise already explains the residuals).  Drawing c + s F z, z ~ N(0, I),
and pushing every draw through the same grid analysis gives the spread of
S, k1, k2 and the radius through the non-linear maps (the delta method
J Cov J^T breaks down at umbilics, where S has a kink).
"""

import numpy as np

N_DRAWS = 64
Z95 = 1.959963984540054


def residual_scale(chi2, dof, noise_stated):
    """Variance factor s^2 for the covariance; None when the fit has no spare rows."""
    if dof <= 0:
        return 1.0 if noise_stated else None
    s2 = chi2 / dof
    return max(s2, 1.0) if noise_stated else s2


def coefficient_draws(coef, cov_factor, s2, n_draws=N_DRAWS, seed=0):
    """(p, n_draws) coefficient samples from N(coef, s2 F F^T), seeded."""
    z = np.random.default_rng(seed).standard_normal((cov_factor.shape[1], n_draws))
    return coef[:, None] + np.sqrt(s2) * (cov_factor @ z)


def interval(estimate, samples, lo=-np.inf, hi=np.inf):
    """95 % interval estimate +/- 1.96 sd(samples), clipped to [lo, hi].

    The draws give the spread; a Gaussian interval from their standard
    deviation is steadier with 64 draws than their 2.5/97.5 percentiles.
    """
    sd = float(np.std(samples, ddof=1))
    return (max(estimate - Z95 * sd, lo), min(estimate + Z95 * sd, hi)), sd
