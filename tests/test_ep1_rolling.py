"""Montana's rolling kinematics (eqs. 24-28) checked against rigid-body motion and eq. 38."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tactile_sim.ep1 import surfaces as S
from tactile_sim.ep1.probes import measure, simulate_probes, sphere_plus_probes
from tactile_sim.ep1.rolling import finger_pose, rhs, roll, sphere_on_sphere

FINGER = S.fingertip(1.0)


@pytest.mark.parametrize("R2", [2.0, 0.3, 50.0, -3.0])
@pytest.mark.parametrize("omega", [(1.0, 0.0), (0.0, -1.0), (0.6, 0.8), (-0.3, 0.2)])
def test_ode_matches_sphere_closed_form(R2, omega):
    obj = S.sphere(abs(R2)) if R2 > 0 else None
    if obj is None:  # concave sphere: inside of a spherical cup, normal towards the centre
        return _concave_check(R2, omega)
    res = roll(FINGER, obj, (0.1, -0.2), (0.0, 0.0), 0.3, (*omega, 0.0), duration=0.4)
    u, v, s = sphere_on_sphere(1.0, R2, 0.1, -0.2, omega[0], omega[1], 0.4)
    assert res.status == "done"
    np.testing.assert_allclose(res.y[:2], [u, v], atol=1e-9)
    assert res.y[5] == pytest.approx(s, rel=1e-9)


def _concave_check(R2, omega):
    # eq. 38 with R2 < 0 is the same ODE with K2 = I / R2: integrate eq. 24 directly.
    c = R2 / (1.0 + R2)
    sol = solve_ivp(
        lambda t, p: [-omega[1] * c, omega[0] * c / np.cos(p[0])],
        (0, 0.4),
        [0.1, -0.2],
        rtol=1e-12,
        atol=1e-12,
    )
    u, v, _ = sphere_on_sphere(1.0, R2, 0.1, -0.2, omega[0], omega[1], 0.4)
    np.testing.assert_allclose([u, v], sol.y[:, -1], atol=1e-9)


@pytest.mark.parametrize(
    "obj",
    [
        S.paraboloid(1.0),
        S.ellipsoid(1.5, 0.8, 1.2),
        S.saddle(0.4, 0.3),
        S.torus(2.0, 0.7),
        S.cylinder(2.0, concave=True),
    ],
    ids=lambda s: s.name,
)
def test_rigid_finger_rolls_without_slipping_at_commanded_rate(obj):
    """Rebuild the finger pose from (p1, p2, psi): the material point at the contact has zero
    velocity and the body angular velocity equals omega in the contact frame (so eq. 27's
    torsion terms and signs are right)."""
    omega = np.array([0.6, 0.8, 0.0])
    y0 = np.array([0.2, -0.1, 0.3, 0.2, 0.4, 0.0])
    sol = solve_ivp(
        rhs,
        (0, 0.6),
        y0,
        method="DOP853",
        rtol=1e-12,
        atol=1e-12,
        args=(FINGER, obj, omega),
        dense_output=True,
    )
    h = 1e-5
    for t in (0.1, 0.3, 0.55):
        y = sol.sol(t)
        R, _ = finger_pose(FINGER, obj, y)
        Rp, tp = finger_pose(FINGER, obj, sol.sol(t + h))
        Rm, tm = finger_pose(FINGER, obj, sol.sol(t - h))
        W = (Rp - Rm) / (2 * h) @ R.T
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        g1 = S.local(FINGER, y[0], y[1])
        F1 = R @ np.column_stack([g1.x, g1.y, g1.z])
        np.testing.assert_allclose(F1.T @ w, omega, atol=1e-7)
        slip = ((Rp @ g1.point + tp) - (Rm @ g1.point + tm)) / (2 * h)
        np.testing.assert_allclose(slip, 0.0, atol=1e-7)


def test_finger_pose_puts_contact_points_together_with_opposite_normals():
    obj = S.ellipsoid(1.5, 0.8, 1.2)
    y = np.array([0.3, -0.2, 0.5, 1.0, 0.7, 0.0])
    R, t = finger_pose(FINGER, obj, y)
    g1, g2 = S.local(FINGER, 0.3, -0.2), S.local(obj, 0.5, 1.0)
    np.testing.assert_allclose(R @ g1.point + t, g2.point, atol=1e-14)
    np.testing.assert_allclose(R @ g1.z, -g2.z, atol=1e-14)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-14)


def test_chart_exit_events_stop_cleanly():
    res = roll(FINGER, S.plane(), (0, 0), (0, 0), 0.0, (0.0, 3.0, 0.0))  # finger u past pi/2
    assert res.status == "chart_exit:finger"
    assert abs(res.y[0]) == pytest.approx(np.pi / 2 - 1e-6, abs=1e-9)
    small = S.paraboloid(1.0, half_width=0.05)
    res = roll(FINGER, small, (0, 0), (0, 0), 0.0, (1.0, 0.0, 0.0))
    assert res.status == "chart_exit:object"
    assert res.t < 1.0


def test_contact_lost_event_when_curvatures_stop_nesting():
    """Rolling towards a torus's inner equator: its negative curvature -cos u / (R + r cos u)
    reaches -1/R1 at cos u = -R / (R1 + r), where K1 + K2~ turns singular (eq. 24)."""
    obj = S.torus(1.05, 0.5)
    res = roll(FINGER, obj, (0, 0), (2.0, 0.0), 0.0, (0.0, -3.0, 0.0), duration=1.0)
    assert res.status == "contact_lost"
    assert res.y[2] == pytest.approx(np.arccos(-1.05 / 1.5), abs=1e-6)
    assert res.t < 1.0


def test_return_probe_retraces_exactly():
    obj = S.ellipsoid(1.5, 0.8, 1.2)
    out = roll(FINGER, obj, (0, 0), (0.2, 0.3), 0.0, (0.3, 0.1, 0.0))
    back = roll(FINGER, obj, out.y[:2], out.y[2:4], out.y[4], (-0.3, -0.1, 0.0))
    np.testing.assert_allclose(back.y[:5], [0, 0, 0.2, 0.3, 0.0], atol=1e-9)


@pytest.mark.parametrize("R2", [0.05, 1.0, 20.0])
def test_sphere_fast_path_equals_ode_probes(R2):
    fast = sphere_plus_probes(1.0, R2, 0.2)
    ode = simulate_probes(FINGER, S.sphere(R2), (0, 0), (0, 0), 0.2)
    np.testing.assert_allclose(measure(fast, 1.0), measure(ode, 1.0), atol=1e-9)
    np.testing.assert_allclose(fast.ds, ode.ds, rtol=1e-9)


def test_measurement_models():
    pr = sphere_plus_probes(1.0, 2.0, 0.3)
    rng = np.random.default_rng(1)
    exact = measure(pr, 1.0)
    arr = measure(pr, 1.0, resolution=0.05, sensor="array")
    steps = arr[:, 2:] / 0.05
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)  # whole elements
    assert np.all(np.abs(arr[:, 2:] - exact[:, 2:]) <= 0.025 + 1e-12)
    bias = measure(pr, 1.0, resolution=0.01, sensor="bias")
    moved = np.abs(bias[:, 2:] - exact[:, 2:]).sum(axis=1)
    np.testing.assert_allclose(moved, 0.01)
    noisy = measure(pr, 1.0, sigma_theta=0.01, rng=rng)
    d = noisy[:, :2] - exact[:, :2]
    np.testing.assert_allclose(
        d[:, 0] * pr.axis[:, 1] - d[:, 1] * pr.axis[:, 0], 0.0, atol=1e-15
    )  # along the axis
    with pytest.raises(ValueError, match="unknown sensor"):
        measure(pr, 1.0, sensor="camera")
