"""Peer estimators for the benchmarks, on the same contacts.

- ``fitpack``: scipy FITPACK ``bisplrep`` smoothing spline on positions only
  (s = n sigma_pos^2), curvature averaged over the same N x N grid.
- ``lsq_spline``: ``LSQBivariateSpline`` without interior knots (positions only).
- ``jet``: quadric (2-jet) least squares z = c + g.x + x^T A x / 2 about the
  patch centre, curvature at the centre; ``with_normals`` adds the slope rows
  weighted 1/sigma as in the main fit.

All work in the patch frame of ``patch_frame`` and share ``surface_geometry``
for curvature, so only the surface estimate differs.
"""

import numpy as np

from tactile.ep2 import patch_frame
from tactile.ep2.surface_geometry import curvatures


def _framed(points, normals):
    nrm = patch_frame.unit_normals(normals)
    frame = patch_frame.frame_from_contacts(points, nrm)
    p = frame.to_patch(points)
    sx, sy = patch_frame.slopes(frame.to_patch_dirs(nrm), 89.0)
    return p, sx, sy


def _grid(p, n):
    xs = np.linspace(p[:, 0].min(), p[:, 0].max(), n)
    ys = np.linspace(p[:, 1].min(), p[:, 1].max(), n)
    return xs, ys


def fitpack(points, normals, noise_pos, grid=8, degree=3):
    """(k1, k2) grid arrays from ``scipy.interpolate.bisplrep`` (positions only).

    bisplev needs derivative order < degree, so second derivatives need
    degree 3; s = n max(sigma, 1e-4)^2 (an interpolating s = 0 is ill-posed
    with repeated readings).
    """
    import warnings

    from scipy.interpolate import bisplev, bisplrep

    p, _, _ = _framed(points, normals)
    s = len(p) * max(noise_pos, 1e-4) ** 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tck = bisplrep(p[:, 0], p[:, 1], p[:, 2], kx=degree, ky=degree, s=s, quiet=1)
    xs, ys = _grid(p, grid)
    d = [bisplev(xs, ys, tck, dx, dy) for dx, dy in ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))]
    return curvatures(*d)


def lsq_spline(points, normals, grid=8, degree=3):
    """(k1, k2) grid arrays from ``LSQBivariateSpline`` with no interior knots.

    Degree 3 is the lowest whose second derivatives FITPACK evaluates; with
    three finger lines the x direction is then rank deficient and FITPACK
    returns its own minimum-norm-like solution (warning suppressed).
    """
    import warnings

    from scipy.interpolate import LSQBivariateSpline

    p, _, _ = _framed(points, normals)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        spl = LSQBivariateSpline(p[:, 0], p[:, 1], p[:, 2], [], [], kx=degree, ky=degree)
    xs, ys = _grid(p, grid)
    d = [spl(xs, ys, dx=dx, dy=dy) for dx, dy in ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))]
    return curvatures(*d)


def jet(points, normals, noise_pos=1.0, noise_normal=1.0, with_normals=True, debias=False):
    """(k1, k2) at the patch centre from a 2-jet (quadric) least-squares fit.

    ``debias`` applies this package's anisotropy correction (``uncertainty.anisotropy``,
    with the jet's own covariance) - an ablation showing what that step alone gives.
    """
    p, sx, sy = _framed(points, normals)
    c = 0.5 * (p.min(axis=0) + p.max(axis=0))
    x, y, z = p[:, 0] - c[0], p[:, 1] - c[1], p[:, 2]
    one, zero = np.ones_like(x), np.zeros_like(x)
    rows = [np.column_stack([one, x, y, 0.5 * x * x, x * y, 0.5 * y * y])]
    rhs = [z]
    w = [np.full(len(x), 1.0 / max(noise_pos, 1e-12))]
    if with_normals:
        rows += [
            np.column_stack([zero, one, zero, x, y, zero]),
            np.column_stack([zero, zero, one, zero, x, y]),
        ]
        rhs += [sx, sy]
        w += [np.full(len(x), 1.0 / max(noise_normal, 1e-12))] * 2
    A = np.vstack(rows) * np.concatenate(w)[:, None]
    b = np.concatenate(rhs) * np.concatenate(w)
    coef = np.linalg.lstsq(A, b, rcond=None)[0]
    if debias:
        from tactile.ep2 import uncertainty

        channels = [np.array([v]) for v in coef[1:6]]
        t, G = uncertainty.tensor_and_jacobian(channels, np.eye(6)[1:6])
        r = b - A @ coef
        s2 = max(float(r @ r) / (A.shape[0] - 6), 1.0)  # the noise is stated
        cov = uncertainty.tensor_cov(G, np.linalg.pinv(A), s2)
        m, h, _ = uncertainty.anisotropy(t, cov)
        return np.atleast_1d(m + h), np.atleast_1d(m - h)
    k1, k2 = curvatures(coef[1], coef[2], coef[3], coef[4], coef[5])
    return np.atleast_1d(k1), np.atleast_1d(k2)
