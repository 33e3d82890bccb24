"""Independent checks of the EP2 jet's building blocks, each against a route it shares nothing with.

Guards:
- ``jet_basis.round_excess`` + the quadric IS a sphere / a cylinder of any axis (and their
  concave twins): height and slopes against z = -(R - sqrt(R^2 - r^2)) written out by hand;
- ``round_second`` and ``round_excess``'s own slopes against central finite differences;
- ``design``: derivative rows against finite differences of the position rows, and its
  coefficients are the partial derivatives at the centre (``CHANNELS``, ``HESSIAN``);
- ``centre_result.widen(nu)`` = q F_q,nu(0.95) / chi2_q(0.95) from ``scipy.stats``, -> 1.
"""

import math

import numpy as np
import pytest
from scipy import stats

from tactile.ep2 import centre_result, jet_basis


def _rng(seed):
    return np.random.default_rng(seed)


def _inside_disc(rng, n, radius):
    """n points uniform in a disc of ``radius`` (x, y arrays)."""
    r = radius * np.sqrt(rng.uniform(0.0, 1.0, n))
    a = rng.uniform(0.0, 2 * np.pi, n)
    return r * np.cos(a), r * np.sin(a)


def _round_surface(x, y, H):
    """Quadric plus the round excess: (z, z_x, z_y)."""
    ex, ex_x, ex_y = jet_basis.round_excess(x, y, H)
    a, b, c = H[0, 0], H[0, 1], H[1, 1]
    z = 0.5 * (a * x * x + 2 * b * x * y + c * y * y) + ex
    return z, a * x + b * y + ex_x, b * x + c * y + ex_y


# --- the closed form is exact for spheres and cylinders ---------------------------------


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("sign", [1.0, -1.0])  # convex toward +z (sphere) / concave (pit)
def test_round_excess_plus_quadric_is_exactly_a_sphere(seed, sign):
    rng = _rng(seed)
    R = 10 ** rng.uniform(-0.5, 2.0)
    # up to Q2 = 0.99 (normals 84 deg off): inside ROUND_MAX_Q2, where nothing is clamped
    x, y = _inside_disc(rng, 200, 0.995 * R)
    z, zx, zy = _round_surface(x, y, -sign / R * np.eye(2))
    root = np.sqrt(R * R - x * x - y * y)
    np.testing.assert_allclose(z, -sign * (R - root), rtol=1e-12, atol=1e-12 * R)
    np.testing.assert_allclose(zx, -sign * x / root, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(zy, -sign * y / root, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_round_excess_plus_quadric_is_exactly_a_cylinder_of_any_axis(seed, sign):
    rng = _rng(100 + seed)
    R = 10 ** rng.uniform(-0.5, 2.0)
    phi = rng.uniform(0.0, np.pi)  # direction across the axis (the curved one)
    e = np.array([np.cos(phi), np.sin(phi)])
    # contacts anywhere along the axis, across it up to 0.995 R
    u = rng.uniform(-0.995 * R, 0.995 * R, 200)
    v = rng.uniform(-5 * R, 5 * R, 200)
    x, y = u * e[0] - v * e[1], u * e[1] + v * e[0]
    z, zx, zy = _round_surface(x, y, -sign / R * np.outer(e, e))
    across = x * e[0] + y * e[1]
    root = np.sqrt(R * R - across * across)
    np.testing.assert_allclose(z, -sign * (R - root), rtol=1e-12, atol=1e-12 * R)
    np.testing.assert_allclose(zx, -sign * across * e[0] / root, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(zy, -sign * across * e[1] / root, rtol=1e-12, atol=1e-12)


def test_round_excess_is_zero_for_a_plane_and_broadcasts_over_a_batch():
    rng = _rng(7)
    x, y = rng.normal(size=(2, 3, 11))
    H = np.stack([np.zeros((2, 2)), -0.1 * np.eye(2), np.diag([0.0, 0.2])])
    ez, ex, ey = jet_basis.round_excess(x, y, H)
    assert ez.shape == ex.shape == ey.shape == (3, 11)
    assert not np.any(ez[0]) and not np.any(ex[0]) and not np.any(ey[0])
    for b in range(3):
        one = jet_basis.round_excess(x[b], y[b], H[b])
        for got, want in zip((ez[b], ex[b], ey[b]), one):
            np.testing.assert_array_equal(got, want)


# --- derivatives against finite differences ----------------------------------------------


def _random_H(rng):
    a, b, c = rng.uniform(-0.6, 0.6, 3)
    return np.array([[a, b], [b, c]])


@pytest.mark.parametrize("seed", range(5))
def test_round_excess_slopes_and_round_second_match_central_differences(seed):
    rng = _rng(300 + seed)
    H = _random_H(rng)
    x, y = _inside_disc(rng, 30, 0.9 / max(np.abs(np.linalg.eigvalsh(H)).max(), 1e-3))
    h = 1e-6
    ez = [
        jet_basis.round_excess(x + dx, y + dy, H) for dx, dy in ((h, 0), (-h, 0), (0, h), (0, -h))
    ]
    _, ex, ey = jet_basis.round_excess(x, y, H)
    np.testing.assert_allclose(ex, (ez[0][0] - ez[1][0]) / (2 * h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(ey, (ez[2][0] - ez[3][0]) / (2 * h), rtol=1e-6, atol=1e-9)
    exx, exy, eyy = jet_basis.round_second(x, y, H)
    np.testing.assert_allclose(exx, (ez[0][1] - ez[1][1]) / (2 * h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(exy, (ez[2][1] - ez[3][1]) / (2 * h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(exy, (ez[0][2] - ez[1][2]) / (2 * h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(eyy, (ez[2][2] - ez[3][2]) / (2 * h), rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("order", [2, 3, 5])
def test_design_derivative_rows_match_differences_of_position_rows(order):
    rng = _rng(order)
    x, y = rng.uniform(-1.0, 1.0, (2, 25))
    coef = rng.normal(size=jet_basis.n_coef(order))
    h = 1e-5

    def z(dx=0.0, dy=0.0):
        return jet_basis.design(x + dx, y + dy, order, ((0, 0),)) @ coef

    rows = jet_basis.design(x, y, order, ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2)))
    assert rows.shape == (5 * 25, jet_basis.n_coef(order))
    zx, zy, zxx, zxy, zyy = np.split(rows @ coef, 5)
    np.testing.assert_allclose(zx, (z(h) - z(-h)) / (2 * h), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(zy, (z(0, h) - z(0, -h)) / (2 * h), rtol=1e-7, atol=1e-8)
    g = 1e-3  # second differences: O(g^2) truncation, O(eps / g^2) round-off
    np.testing.assert_allclose(zxx, (z(g) - 2 * z() + z(-g)) / g**2, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(zyy, (z(0, g) - 2 * z() + z(0, -g)) / g**2, rtol=1e-5, atol=1e-5)
    mixed = (z(g, g) - z(g, -g) - z(-g, g) + z(-g, -g)) / (4 * g * g)
    np.testing.assert_allclose(zxy, mixed, rtol=1e-5, atol=1e-5)
    # the default derivs are (position, x-slope, y-slope), stacked in that order
    pos = jet_basis.design(x, y, order, ((0, 0),))
    np.testing.assert_array_equal(jet_basis.design(x, y, order), np.vstack([pos, rows[:50]]))


@pytest.mark.parametrize("order", [2, 3, 4])
def test_jet_coefficients_are_the_partial_derivatives_at_the_centre(order):
    """At (0, 0) the row of derivative (i, j) picks coefficient (i, j) alone: the Taylor
    normalisation, and the columns ``CHANNELS`` / ``HESSIAN`` name."""
    zero = np.zeros(1)
    names = jet_basis.monomials(order)
    assert len(names) == jet_basis.n_coef(order) == len(set(names))
    for k, ij in enumerate(names):
        row = jet_basis.design(zero, zero, order, (ij,))[0]
        np.testing.assert_array_equal(row, np.eye(len(names))[k])
    derivs = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    assert tuple(names.index(d) for d in derivs) == jet_basis.CHANNELS
    assert tuple(names.index(d) for d in derivs[2:]) == jet_basis.HESSIAN
    coef = np.arange(1.0, len(names) + 1)
    np.testing.assert_array_equal(jet_basis.hessian(coef), [[4.0, 5.0], [5.0, 6.0]])


# --- the F widening ----------------------------------------------------------------------


@pytest.mark.parametrize("q", [1, 2, 3])
@pytest.mark.parametrize("nu", [1.0, 1.5, 2.0, 3.7, 10.0, 30.0, 250.0, 1e4])
def test_widen_is_q_F_over_chi2(q, nu):
    want = q * stats.f.ppf(0.95, q, nu) / stats.chi2.ppf(0.95, q)
    assert centre_result.widen(nu, q=q) == pytest.approx(want, rel=1e-9)


def test_widen_tends_to_one_and_decreases():
    nus = [1.0, 2.0, 5.0, 20.0, 100.0, 1e3, 1e5, 1e7]
    w = [centre_result.widen(v) for v in nus]
    assert all(a > b for a, b in zip(w, w[1:]))
    assert w[0] > 10.0  # one degree of freedom: the F tail is far wider than chi^2
    assert w[-1] == pytest.approx(1.0, abs=1e-5) and w[-1] > 1.0
    assert centre_result.widen(math.inf) == 1.0
