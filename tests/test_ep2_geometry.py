"""EP2 differential geometry checked by independent routes (closed forms, eig of I^-1 II)."""

import numpy as np
import pytest

from tactile.ep2.geometry import (
    curvatures,
    curvedness_c,
    curvedness_r,
    hk_labels,
    principal,
    s_region_map,
    shape_index,
    shape_operator,
)


def _sphere_derivs(R, x, y):
    """Cap z = sqrt(R^2 - r^2) - R (convex toward +z): analytic derivatives."""
    w = np.sqrt(R * R - x * x - y * y)
    zx, zy = -x / w, -y / w
    zxx = -(R * R - y * y) / w**3
    zyy = -(R * R - x * x) / w**3
    zxy = -x * y / w**3
    return zx, zy, zxx, zxy, zyy


def _eig_route(zx, zy, zxx, zxy, zyy):
    """Independent route: eigenvalues of I^-1 II (textbook, eqs. 5-16), sign flipped."""
    out = []
    for v in np.broadcast(zx, zy, zxx, zxy, zyy):
        a, b, c, d, e = v
        W = np.sqrt(1 + a * a + b * b)
        first = np.array([[1 + a * a, a * b], [a * b, 1 + b * b]])
        second = -np.array([[c, d], [d, e]]) / W
        ev = np.sort(np.linalg.eigvals(np.linalg.solve(first, second)).real)[::-1]
        out.append(ev)
    return np.array(out)


@pytest.mark.parametrize("R", [1e-3, 1.0, 6.6, 1e3])
def test_sphere_is_umbilic_everywhere_with_positive_curvature(R):
    x = np.linspace(-0.6, 0.6, 7) * R
    X, Y = np.meshgrid(x, x)
    k1, k2 = curvatures(*_sphere_derivs(R, X, Y))
    assert np.allclose(k1, 1 / R, rtol=1e-10)
    assert np.allclose(k2, 1 / R, rtol=1e-10)
    assert np.all(k1 >= k2)


def test_exact_umbilic_and_plane_have_no_roundoff_split():
    k1, k2 = curvatures(0.0, 0.0, -2.0, 0.0, -2.0)
    assert k1 == k2 == 2.0
    k1, k2 = curvatures(0.3, -0.7, 0.0, 0.0, 0.0)
    assert k1 == 0.0 and k2 == 0.0


def test_cylinder_closed_form_at_any_rotation():
    R = 4.0
    for rot in np.radians([0, 10, 45, 80]):
        u = 1.3  # distance across the axis
        w = np.sqrt(R * R - u * u)
        zu, zuu = -u / w, -(R * R) / w**3
        c, s = np.cos(rot), np.sin(rot)
        zx, zy = zu * c, zu * s
        zxx, zxy, zyy = zuu * c * c, zuu * c * s, zuu * s * s
        geo = principal(zx, zy, zxx, zxy, zyy)
        assert geo["k1"] == pytest.approx(1 / R, rel=1e-12)
        assert geo["k2"] == pytest.approx(0.0, abs=1e-14)
        # k1 direction is across the axis: horizontal part along (cos, sin)
        d = geo["dir1"]
        assert abs(d[0] * s - d[1] * c) < 1e-12


def test_random_surfaces_match_eigenvalues_of_first_form_inverse_times_second():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(5, 200)) * np.array([[2], [2], [3], [3], [3]])
    geo = principal(*v)
    ref = _eig_route(*v)
    assert np.allclose(geo["k1"], ref[:, 0], atol=1e-12, rtol=1e-10)
    assert np.allclose(geo["k2"], ref[:, 1], atol=1e-12, rtol=1e-10)
    assert np.allclose(geo["K"], ref[:, 0] * ref[:, 1], atol=1e-12)


def test_principal_direction_is_eigenvector_of_weingarten_map():
    rng = np.random.default_rng(4)
    zx, zy, zxx, zxy, zyy = rng.normal(size=5)
    geo = principal(zx, zy, zxx, zxy, zyy)
    d = geo["dir1"]
    # direction in parameter coordinates: d = du X_x + dv X_y
    du, dv = d[0], d[1]
    assert d[2] == pytest.approx(du * zx + dv * zy, abs=1e-12)
    W = np.sqrt(1 + zx * zx + zy * zy)
    first = np.array([[1 + zx * zx, zx * zy], [zx * zy, 1 + zy * zy]])
    second = -np.array([[zxx, zxy], [zxy, zyy]]) / W
    lhs = second @ [du, dv]
    rhs = geo["k1"] * (first @ [du, dv])
    assert np.allclose(lhs, rhs, atol=1e-12)
    assert np.linalg.norm(d) == pytest.approx(1.0)


def test_shape_operator_entries_agree_with_direct_formula():
    rng = np.random.default_rng(5)
    v = rng.normal(size=(5, 50))
    a, b, c, (e1, e2) = shape_operator(*v)
    assert np.allclose(np.einsum("ij,ij->i", e1, e2), 0, atol=1e-12)
    assert np.allclose(np.linalg.norm(e1, axis=1), 1) and np.allclose(np.linalg.norm(e2, axis=1), 1)


def test_curvature_against_finite_differences_of_a_height_field():
    """Derivatives by central differences of z = sqrt(R^2 - r^2) - R give the same k."""
    R, h = 5.0, 1e-4

    def f(x, y):
        return np.sqrt(R * R - x * x - y * y) - R

    x, y = 1.1, -0.7
    zx = (f(x + h, y) - f(x - h, y)) / (2 * h)
    zy = (f(x, y + h) - f(x, y - h)) / (2 * h)
    zxx = (f(x + h, y) - 2 * f(x, y) + f(x - h, y)) / h**2
    zyy = (f(x, y + h) - 2 * f(x, y) + f(x, y - h)) / h**2
    zxy = (f(x + h, y + h) - f(x + h, y - h) - f(x - h, y + h) + f(x - h, y - h)) / (4 * h * h)
    k1, k2 = curvatures(zx, zy, zxx, zxy, zyy)
    assert k1 == pytest.approx(1 / R, rel=1e-5) and k2 == pytest.approx(1 / R, rel=1e-5)


@pytest.mark.parametrize(
    "k1,k2,S",
    [(1, 1, 1.0), (1, 0, 0.5), (1, -1, 0.0), (0, -1, -0.5), (-1, -1, -1.0), (2, 1, None)],
)
def test_shape_index_canonical_values(k1, k2, S):
    s = shape_index(np.float64(k1), np.float64(k2))
    if S is None:
        assert s == pytest.approx(2 / np.pi * np.arctan(3.0))
    else:
        assert s == pytest.approx(S, abs=1e-15)


def test_curvedness_and_c():
    assert curvedness_r(3.0, 4.0) == pytest.approx(np.sqrt(12.5))
    assert curvedness_r(1e200, 1e200) == pytest.approx(1e200)  # no overflow
    assert curvedness_c(1.0) == 0.0
    assert curvedness_c(np.e) == pytest.approx(2 / np.pi)


def test_hk_tables_and_s_regions():
    K = np.array([-1, -1, -1, 0, 0, 0, 1, 1.0])
    H = np.array([-1, 0, 1, -1, 0, 1, -1, 1.0])
    labels = hk_labels(K, H, 1e-9, 1e-9, table=2).tolist()
    assert labels == [
        "saddle_valley",
        "minimal_saddle",
        "saddle_ridge",
        "valley",
        "flat",
        "ridge",
        "pit",
        "peak",
    ]
    t1 = hk_labels(np.array([1.0, 1.0, -1, -1]), np.array([1.0, -1, 1, -1]), table=1).tolist()
    assert t1 == ["convex", "concave", "saddle_ridge", "saddle_valley"]
    regions = s_region_map(np.array([1.0, 0.5, 0.0, -0.5, -1.0])).tolist()
    assert regions == ["sphere", "cylinder", "saddle", "concave_cylinder", "concave_sphere"]


@pytest.mark.parametrize("table", [1, 2])
def test_one_pair_gets_the_label_its_array_gets(table):
    """A patch's one (K, H) pair (a 0-d array) is labelled as the same pair in an array,
    zero bands, NaN and both tables included."""
    values = [-2.0, -1e-9, 0.0, 1e-9, 2.0, np.nan]
    K, H = (np.array(v).ravel() for v in np.meshgrid(values, values))
    want = hk_labels(K, H, 1e-9, 2e-9, table=table).tolist()
    got = [hk_labels(np.array(k), np.array(h), 1e-9, 2e-9, table=table) for k, h in zip(K, H)]
    assert all(g.shape == () for g in got)
    assert [str(g[()]) for g in got] == want
