"""EP2 B-spline patch fit: basis rows, exact recovery, solvers, rank checks."""

import numpy as np
import pytest
from scipy.interpolate import BSpline

from tactile.ep2 import spline as bp
from tactile.errors import DataError


@pytest.mark.parametrize("degree", [2, 3, 4, 5])
@pytest.mark.parametrize("nu", [0, 1, 2])
def test_power_table_rows_equal_scipy_bspline(degree, nu):
    t = bp.knots(degree)
    u = np.linspace(-0.2, 1.2, 23)  # includes extrapolation
    ref = BSpline(np.array(t), np.eye(degree + 1), degree, extrapolate=True)(u, nu)
    assert np.allclose(bp.basis(u, degree, t, nu), ref, atol=1e-11)


def test_multi_segment_basis_uses_bspline_and_partition_of_unity():
    t = bp.knots(3, segments=3)
    u = np.linspace(0, 1, 31)
    rows = bp.basis(u, 3, t, 0)
    assert rows.shape == (31, 6)
    assert np.allclose(rows.sum(axis=1), 1.0)
    assert np.allclose(bp.basis(u, 3, t, 1).sum(axis=1), 0.0, atol=1e-12)


def _poly_surface(x, y):
    z = 0.3 + 0.2 * x - 0.1 * y + 0.05 * x * x - 0.08 * x * y + 0.04 * y * y + 0.01 * x * x * y * y
    zx = 0.2 + 0.1 * x - 0.08 * y + 0.02 * x * y * y
    zy = -0.1 - 0.08 * x + 0.08 * y + 0.02 * x * x * y
    return z, zx, zy


def _scatter(n=36, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 4, n), rng.uniform(0, 4, n)


@pytest.mark.parametrize("solver", ["svd", "qr", "gelsy"])
def test_biquadratic_recovers_a_surface_in_its_span_exactly(solver):
    x, y = _scatter()
    z, zx, zy = _poly_surface(x, y)
    fit = bp.fit_patch(x, y, z, zx, zy, 1.0, 1.0, 1.0, degree=(2, 2), solver=solver)
    gx, gy = np.meshgrid(np.linspace(0.2, 3.8, 5), np.linspace(0.2, 3.8, 5))
    d = fit.derivatives(gx.ravel(), gy.ravel())
    z2, zx2, zy2 = _poly_surface(gx.ravel(), gy.ravel())
    assert np.allclose(d[0], z2, atol=1e-10)
    assert np.allclose(d[1], zx2, atol=1e-10) and np.allclose(d[2], zy2, atol=1e-10)
    # second derivatives of the exact surface
    X, Y = gx.ravel(), gy.ravel()
    assert np.allclose(d[3], 0.1 + 0.02 * Y * Y, atol=1e-9)
    assert np.allclose(d[4], -0.08 + 0.04 * X * Y, atol=1e-9)
    assert np.allclose(d[5], 0.08 + 0.02 * X * X, atol=1e-9)


def test_derivative_rows_match_finite_differences_of_fitted_surface():
    x, y = _scatter(seed=1)
    z = np.sin(x) * np.cos(0.5 * y)
    fit = bp.fit_patch(
        x,
        y,
        z,
        np.cos(x) * np.cos(0.5 * y),
        -0.5 * np.sin(x) * np.sin(0.5 * y),
        1.0,
        1.0,
        1.0,
        degree=(4, 3),
    )
    px, py, h = np.array([1.3]), np.array([2.1]), 1e-4

    def zf(a, b):
        return fit.derivatives(a, b)[0][0]

    d = [v[0] for v in fit.derivatives(px, py)]
    assert d[1] == pytest.approx((zf(px + h, py) - zf(px - h, py)) / (2 * h), rel=1e-6)
    assert d[2] == pytest.approx((zf(px, py + h) - zf(px, py - h)) / (2 * h), rel=1e-6)
    fd_xx = (zf(px + h, py) - 2 * zf(px, py) + zf(px - h, py)) / h**2
    assert d[3] == pytest.approx(fd_xx, rel=1e-4, abs=1e-6)
    fd_xy = zf(px + h, py + h) - zf(px + h, py - h) - zf(px - h, py + h) + zf(px - h, py - h)
    assert d[4] == pytest.approx(fd_xy / (4 * h * h), rel=1e-4, abs=1e-6)


def test_slopes_alone_add_rank_across_three_fingers():
    """Three finger lines: positions only cannot fix a quartic in x; slopes can."""
    x = np.repeat([0.0, 2.0, 4.0], 6)
    y = np.tile(np.linspace(0, 4, 6), 3)
    z, zx, zy = _poly_surface(x, y)
    with pytest.raises(DataError, match="too few points"):
        bp.fit_patch(x, y, z, zx, zy, 1.0, 0.0, 0.0, degree=(3, 2))
    fit = bp.fit_patch(x, y, z, zx, zy, 1.0, 1.0, 1.0, degree=(3, 2))
    assert fit.rank == 12


def test_single_finger_line_is_refused_with_reason():
    y = np.linspace(0, 4, 12)
    x = 0.5 * y  # one straight line in the plane
    z = np.zeros_like(x)
    with pytest.raises(DataError, match="one line"):
        bp.fit_patch(x, y, z, z, z, 1.0, 1.0, 1.0)


def test_too_few_points_for_the_order():
    x, y = _scatter(n=3, seed=2)
    z = np.zeros(3)
    with pytest.raises(DataError, match="too few points for degree 4x4"):
        bp.fit_patch(x, y, z, z, z, 1.0, 1.0, 1.0, degree=(4, 4))


def test_covariance_factor_matches_inverse_of_weighted_normal_matrix():
    x, y = _scatter(seed=3)
    z, zx, zy = _poly_surface(x, y)
    for solver in ("svd", "qr", "gelsy"):
        fit = bp.fit_patch(x, y, z, zx, zy, 2.0, 0.5, 0.5, degree=(2, 2), solver=solver)
        a0, a1, a2 = bp.design(x, y, fit.domain, fit.degree, fit.tx, fit.ty)
        A = np.vstack([2.0 * a0, 0.5 * a1, 0.5 * a2])
        cov = np.linalg.inv(A.T @ A)
        assert np.allclose(fit.cov_factor @ fit.cov_factor.T, cov, rtol=1e-6, atol=1e-12)
