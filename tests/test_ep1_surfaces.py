"""EP1 geometry: every quantity of eqs. 2-4, 13, 16 checked by an independent route."""

import numpy as np
import pytest

from tactile_sim.ep1 import surfaces as S

H = 1e-5

SURFACES = [
    (S.fingertip(1.3), [(0.0, 0.0), (0.4, -0.3), (-0.9, 1.1)]),
    (S.plane(), [(0.0, 0.0), (3.0, -2.0)]),
    (S.sphere(0.7), [(0.0, 0.0), (0.5, 2.0)]),
    (S.cylinder(0.8), [(0.0, 0.0), (1.0, 0.6)]),
    (S.cylinder(2.5, concave=True), [(0.0, 0.0), (-1.0, 0.4)]),
    (S.paraboloid(1.0), [(0.0, 0.0), (1.0, 0.1), (-0.7, 1.2)]),
    (S.ellipsoid(1.5, 0.8, 1.2), [(0.2, 0.3), (-0.6, 1.9)]),
    (S.saddle(0.4, 0.3), [(0.0, 0.0), (0.5, -0.8)]),
    (S.torus(2.0, 0.7), [(0.0, 0.0), (2.0, 0.5), (-1.0, -2.0)]),
]
CASES = [(s, p) for s, pts in SURFACES for p in pts]
IDS = [f"{s.name}@{p}" for s, p in CASES]


def fd(fun, u, v):
    """Central differences of a vector function in u and v."""
    return (
        (np.asarray(fun(u + H, v)) - np.asarray(fun(u - H, v))) / (2 * H),
        (np.asarray(fun(u, v + H)) - np.asarray(fun(u, v - H))) / (2 * H),
    )


@pytest.mark.parametrize(("surf", "p"), CASES, ids=IDS)
def test_derivatives_match_finite_differences(surf, p):
    f, fu, fv, fuu, fuv, fvv = surf.derivs(*p)
    du, dv = fd(lambda u, v: surf.derivs(u, v)[0], *p)
    scale = 1 + np.abs(f).max()
    np.testing.assert_allclose(fu, du, atol=1e-7 * scale)
    np.testing.assert_allclose(fv, dv, atol=1e-7 * scale)
    duu, duv = fd(lambda u, v: surf.derivs(u, v)[1], *p)
    _, dvv = fd(lambda u, v: surf.derivs(u, v)[2], *p)
    np.testing.assert_allclose(fuu, duu, atol=1e-7 * scale)
    np.testing.assert_allclose(fuv, duv, atol=1e-7 * scale)
    np.testing.assert_allclose(fvv, dvv, atol=1e-7 * scale)


@pytest.mark.parametrize(("surf", "p"), CASES, ids=IDS)
def test_frame_metric_curvature_torsion_by_finite_differences(surf, p):
    g = S.local(surf, *p)
    F = np.column_stack([g.x, g.y, g.z])
    np.testing.assert_allclose(F.T @ F, np.eye(3), atol=1e-12)  # orthonormal
    assert np.linalg.det(F) == pytest.approx(1.0)  # right-handed, z = x cross y
    # metric: tangent components of f_u, f_v (finite differences of the point)
    fu, fv = fd(lambda u, v: S.local(surf, u, v).point, *p)
    np.testing.assert_allclose(g.M, F[:, :2].T @ np.column_stack([fu, fv]), atol=1e-6)
    assert g.M[1, 0] == 0.0
    Minv = np.linalg.inv(g.M)
    # curvature form: derivative of the normal (eq. 13), from finite differences of z
    zu, zv = fd(lambda u, v: S.local(surf, u, v).z, *p)
    K_fd = F[:, :2].T @ np.column_stack([zu, zv]) @ Minv
    np.testing.assert_allclose(g.K, K_fd, atol=1e-6 * (1 + np.abs(g.K).max()))
    np.testing.assert_allclose(g.K, g.K.T, atol=1e-12)
    # torsion form: y . derivative of x (eq. 16)
    xu, xv = fd(lambda u, v: S.local(surf, u, v).x, *p)
    T_fd = np.array([g.y @ xu, g.y @ xv]) @ Minv
    np.testing.assert_allclose(g.T, T_fd, atol=1e-6 * (1 + np.abs(g.T).max()))


def test_fingertip_closed_forms_and_thesis_eq22_typo():
    R, u, v = 1.7, 0.4, -0.6
    g = S.local(S.fingertip(R), u, v)
    np.testing.assert_allclose(g.z, [np.cos(u) * np.cos(v), -np.cos(u) * np.sin(v), np.sin(u)])
    np.testing.assert_allclose(g.M, np.diag([R, R * np.cos(u)]), atol=1e-15)  # eq. 23
    np.testing.assert_allclose(g.K, np.eye(2) / R, atol=1e-15)  # eq. 23
    np.testing.assert_allclose(g.T, [0.0, -np.tan(u) / R], atol=1e-15)  # eq. 23
    np.testing.assert_allclose(g.y, [-np.sin(v), -np.cos(v), 0.0], atol=1e-15)  # eq. 22 y
    # eq. 22's x has sin u cos v as second component; the unit f_u has sin u sin v.
    np.testing.assert_allclose(g.x, [-np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)])
    x_thesis = np.array([-np.sin(u) * np.cos(v), np.sin(u) * np.cos(v), np.cos(u)])
    assert np.abs(x_thesis - g.x).max() > 0.1
    assert abs(np.linalg.norm(x_thesis) - 1.0) > 0.02  # not even unit length


@pytest.mark.parametrize("R", [0.001, 1.0, 1000.0])
def test_sphere_and_cylinders(R):
    np.testing.assert_allclose(S.local(S.sphere(R), 0.3, 1.0).K, np.eye(2) / R, atol=1e-12 / R)
    np.testing.assert_allclose(
        S.local(S.cylinder(R), 2.0, 0.3).K, np.diag([0, 1 / R]), atol=1e-12 / R
    )
    np.testing.assert_allclose(
        S.local(S.cylinder(R, True), 2.0, 0.3).K, np.diag([0, -1 / R]), atol=1e-12 / R
    )


def test_paraboloid_against_normal_curvature_and_thesis_table4():
    """kx = II/I along f_u (eq. 9); the thesis's eq. 37 divides by sqrt(1+4C^2u^2) sqrt(1+4C^2v^2)
    instead of sqrt(1+4C^2(u^2+v^2)) (its eq. 80 normal is not unit length), so table 4 differs."""
    u, v = 1.0, 0.1
    table4 = {8: 485.8528, 5: 143.5480, 1: 5.7009, 0.5: 2.8425, 0.1: 5.3040, 0.01: 50.0301}
    for C, r_thesis in table4.items():
        g = S.local(S.paraboloid(C), u, v)
        W = np.sqrt(1 + 4 * C * C * (u * u + v * v))
        E = 1 + 4 * C * C * u * u
        assert g.K[0, 0] == pytest.approx(2 * C / (W * E), rel=1e-12)
        eq37 = 2 * C / ((1 + 4 * C * C * u * u) ** 1.5 * np.sqrt(1 + 4 * C * C * v * v))
        assert 1 / eq37 == pytest.approx(r_thesis, abs=1e-4)  # we reproduce the table's formula
    assert 1 / S.local(S.paraboloid(8), u, v).K[0, 0] == pytest.approx(258.78, rel=1e-4)


def test_ellipsoid_gaussian_and_mean_curvature_against_sympy():
    sp = pytest.importorskip("sympy")
    a, b, c = 1.5, 0.8, 1.2
    u, v = sp.symbols("u v", real=True)
    f = sp.Matrix([a * sp.cos(u) * sp.cos(v), -b * sp.cos(u) * sp.sin(v), c * sp.sin(u)])
    fu, fv = f.diff(u), f.diff(v)
    n = fu.cross(fv)
    n = n / sp.sqrt(n.dot(n))
    E, F, G = fu.dot(fu), fu.dot(fv), fv.dot(fv)
    e, ff, g = -f.diff(u, 2).dot(n), -f.diff(u, v).dot(n), -f.diff(v, 2).dot(n)  # convex +
    Kg = (e * g - ff**2) / (E * G - F**2)  # eq. 10
    Ka = (E * g - 2 * F * ff + G * e) / (2 * (E * G - F**2))
    for p in [(0.2, 0.3), (-0.6, 1.9), (1.2, -2.5)]:
        K = S.local(S.ellipsoid(a, b, c), *p).K
        subs = {u: p[0], v: p[1]}
        assert np.linalg.det(K) == pytest.approx(float(Kg.subs(subs)), rel=1e-10)
        assert 0.5 * np.trace(K) == pytest.approx(float(Ka.subs(subs)), rel=1e-10)


def test_torus_and_saddle_closed_forms():
    R, r, u = 2.0, 0.7, 0.9
    g = S.local(S.torus(R, r), u, 0.4)
    np.testing.assert_allclose(
        np.sort(np.linalg.eigvalsh(g.K)),
        np.sort([1 / r, np.cos(u) / (R + r * np.cos(u))]),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        S.local(S.saddle(0.4, 0.3), 0, 0).K, np.diag([0.8, -0.6]), atol=1e-15
    )


def test_graph_frame_is_gram_schmidt_not_f_v():
    """Where f_u is not perpendicular to f_v the frame's y is not f_v/|f_v| (eq. 2 assumes so)."""
    surf = S.saddle(0.4, 0.3)
    g = S.local(surf, 0.5, -0.8)
    fv = surf.derivs(0.5, -0.8)[2]
    assert abs(g.y @ (fv / np.linalg.norm(fv)) - 1.0) > 1e-3
    assert g.M[0, 1] != 0.0


def test_make_rejects_unknown_kind():
    with pytest.raises(ValueError, match="unknown surface"):
        S.make("cube")


def test_paraboloid_frame_derivative_against_appendix_b_eq85():
    """x_u's z component is -2C/(1+4C^2u^2)^(3/2); eq. 85 prints +2C/sqrt(..) + 8C^3u^2/(..)^1.5."""
    C, u, v = 1.0, 0.7, 0.2
    surf = S.paraboloid(C)
    xu = (S.local(surf, u + H, v).x - S.local(surf, u - H, v).x) / (2 * H)
    E = 1 + 4 * C * C * u * u
    assert xu[2] == pytest.approx(-2 * C / E**1.5, rel=1e-7)
    assert xu[0] == pytest.approx(
        -4 * C * C * u / E**1.5, rel=1e-7
    )  # eq. 85's first entry is right
    thesis = 2 * C / np.sqrt(E) + 8 * C**3 * u * u / E**1.5
    assert abs(thesis - xu[2]) > 1.0
