"""Model bias of the patch curvature: refit of the constant-curvature surface (beyond the thesis).

A biquadratic cannot follow a circle: on a cylinder of radius 8 over a 4 x 4
patch its grid-mean curvature is ~1 % low, which at low noise is several
standard deviations, so intervals from the noise alone miss the truth
(docs/ep2.md, calibration).  The bias is estimated by fitting, with the same
rows, weights and shrinkage (``SplineFit.data_map``, a linear map), noise-free
data from the surface whose shape operator is the estimated one everywhere.
To fourth order about the patch centre c, with A = -P (P the estimated
shape-operator matrix, d = x - c):

    z = (d^T A d)/2 + (d^T A d)(d^T A^2 d)/8

(exact to that order for spheres and cylinders: z = -k r^2/2 - k^3 r^4/8).
The bias vector is the refit's grid-mean entries minus P's; ``api`` adds its
outer product to the covariance of the intervals (not to the estimate: for a
quadric height field the fit itself is unbiased and the term only widens).
"""

import numpy as np


def constant_curvature_data(xy, centre, tensor):
    """(z, slope-x, slope-y) of the constant-shape-operator surface at points ``xy`` (n, 2)."""
    a, b, c = tensor
    A = -np.array([[a, b], [b, c]])
    d = np.asarray(xy, float) - centre
    ad = d @ A
    a2d = ad @ A
    q1 = np.einsum("ij,ij->i", d, ad)
    q2 = np.einsum("ij,ij->i", ad, ad)  # d^T A^2 d
    z = 0.5 * q1 + q1 * q2 / 8.0
    grad = ad + (ad * q2[:, None] + a2d * q1[:, None]) / 4.0
    return z, grad[:, 0], grad[:, 1]


def bias(fit, xy, centre, tensor, grid_tensor):
    """Bias (3,) of the grid-mean entries: refit of ``constant_curvature_data`` minus ``tensor``.

    ``grid_tensor(coef)`` returns the grid-mean entries of a coefficient vector.
    """
    z, gx, gy = constant_curvature_data(xy, centre, tensor)
    coef = fit.data_map @ np.concatenate([z, gx, gy])
    return grid_tensor(coef) - np.asarray(tensor, float)
