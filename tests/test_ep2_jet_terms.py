"""The default fit's jet terms (``tactile.ep2.geometry``) against a route they share nothing with:
derivative rows against finite differences of the value rows, and the coefficients are the
partial derivatives at the centre (the x^i y^j / (i! j!) normalisation)."""

import numpy as np
import pytest

from tactile.ep2.geometry import design, exponents, rows, size, stacked_design


@pytest.mark.parametrize("order", [2, 3, 5])
def test_derivative_rows_match_differences_of_value_rows(order):
    rng = np.random.default_rng(order)
    x, y = rng.uniform(-1.0, 1.0, (2, 25))
    coef = rng.normal(size=size(order))
    h, g = 1e-5, 1e-3  # second differences: O(g^2) truncation, O(eps / g^2) round-off

    def z(dx=0.0, dy=0.0):
        return rows(x + dx, y + dy, order) @ coef

    value, zx, zy = (r @ coef for r in design(x, y, order))
    np.testing.assert_allclose(value, z())
    np.testing.assert_allclose(zx, (z(h) - z(-h)) / (2 * h), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(zy, (z(0, h) - z(0, -h)) / (2 * h), rtol=1e-7, atol=1e-8)
    zxx, zxy, zyy = (rows(x, y, order, *d) @ coef for d in ((2, 0), (1, 1), (0, 2)))
    np.testing.assert_allclose(zxx, (z(g) - 2 * z() + z(-g)) / g**2, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(zyy, (z(0, g) - 2 * z() + z(0, -g)) / g**2, rtol=1e-5, atol=1e-5)
    mixed = (z(g, g) - z(g, -g) - z(-g, g) + z(-g, -g)) / (4 * g * g)
    np.testing.assert_allclose(zxy, mixed, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("order", [2, 3, 4])
def test_coefficients_are_the_partial_derivatives_at_the_centre(order):
    """At (0, 0) the row of derivative (i, j) picks coefficient (i, j) alone; columns run by
    degree, so (zx, zy, zxx, zxy, zyy) are columns 1-5 of every jet."""
    zero = np.zeros(1)
    names = exponents(order)
    assert len(names) == size(order) == len(set(names))
    for k, ij in enumerate(names):
        np.testing.assert_array_equal(rows(zero, zero, order, *ij)[0], np.eye(len(names))[k])
    assert names[1:6] == [(1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]


@pytest.mark.parametrize("shape", [(7,), (3, 12), (2, 3, 4)])
def test_stacked_design_takes_each_product_once_and_equals_the_rows(shape):
    """The fit's design (value, d/dx, d/dy stacked) reads a derivative's column off the
    value's shifted exponents: the same products, bit for bit, as ``rows`` of each."""
    rng = np.random.default_rng(len(shape))
    x, y = rng.normal(size=(2, *shape))
    for order in range(6):
        A = stacked_design(x, y, order)
        want = [rows(x, y, order, *d) for d in ((0, 0), (1, 0), (0, 1))]
        assert A.shape == (*shape[:-1], 3 * shape[-1], size(order))
        np.testing.assert_array_equal(A, np.concatenate(want, -2))
        for got, w in zip(design(x, y, order), want, strict=True):
            np.testing.assert_array_equal(got, w)
