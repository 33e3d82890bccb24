"""EP1 estimator (eqs. 29-33, eq. 64): exact recovery, extremes, statuses and bounds."""

import numpy as np
import pytest
import tolerance
from hypothesis import given, settings
from hypothesis import strategies as st

from tactile.ep1.estimator import STATUSES, estimate, estimate_batch, euler_principal
from tactile_sim.ep1 import surfaces as S
from tactile_sim.ep1.probes import measure, sphere_plus_probes
from tactile_studies.ep1.experiment import run_ep1


def synthetic(K2, R1=1.0, phis=(0.0, 1.0, 2.0, 4.0), dtheta=0.01, u0=0.0):
    """Exact eq. 29 data for a given K2~ along rotation axes phis."""
    S_ = np.linalg.inv(np.eye(2) / R1 + K2)
    th = dtheta * np.column_stack([np.cos(phis), np.sin(phis)])
    a = np.column_stack([-th[:, 1], th[:, 0]])
    b = a @ S_.T
    dp = np.column_stack([b[:, 0] / R1, b[:, 1] / (R1 * np.cos(u0))])
    return th, dp


def test_exact_recovery_of_full_curvature_form_and_principal_directions():
    K2 = np.array([[0.9, -0.3], [-0.3, 0.2]])
    th, dp = synthetic(K2, R1=1.3, u0=0.4)
    e = estimate(th, dp, 1.3, u0=0.4)
    assert e.status == "ok"
    np.testing.assert_allclose(e.K, K2, atol=1e-12)
    w, V = np.linalg.eigh(K2)
    assert (e.k1, e.k2) == pytest.approx((w[1], w[0]), abs=1e-12)
    assert abs(np.dot(e.direction1, V[:, 1])) == pytest.approx(1.0, abs=1e-12)
    assert e.residual < 1e-14


@pytest.mark.parametrize("rcr", [1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0, 1e2, 1e3, 1e4])
def test_relative_curvature_ratio_1e4_range_exact_data(rcr):
    rows = measure(sphere_plus_probes(1.0, rcr, 0.05), 1.0)
    e = estimate(rows[:, :2], rows[:, 2:], 1.0)
    assert e.status in ("ok", "flat")
    assert e.kx == pytest.approx(1 / rcr, rel=1e-7)
    assert e.ky == pytest.approx(1 / rcr, rel=1e-7)
    assert e.direction1 is None  # umbilic: no principal direction


@pytest.mark.parametrize("R2", [0.01, 1.0, 100.0])
def test_relative_curvature_ratio_with_scaled_finger(R2):
    """Same RCR with R1 = 0.01 and R1 = 100: the estimator is scale invariant."""
    for R1 in (0.01, 100.0):
        rows = measure(sphere_plus_probes(R1, R2 * R1, 0.1), R1)
        e = estimate(rows[:, :2], rows[:, 2:], R1)
        assert e.kx * R2 * R1 == pytest.approx(1.0, rel=1e-7)


def test_near_singular_concave_object_gives_status_and_bound_not_numbers():
    """A concave sphere of radius 1.0001 around a unit finger: K1 + K2~ ~ 1e-4 I, under 1e-3
    rad of angle noise the data cannot tell it from singular."""
    rows = measure(
        sphere_plus_probes(1.0, -1.0001, 1e-4), 1.0, sigma_theta=1e-4, rng=np.random.default_rng(0)
    )
    e = estimate(rows[:, :2], rows[:, 2:], 1.0, sigma_theta=1e-4)
    assert e.status == "near_singular"
    assert e.kx is None and e.K is None
    for bound in e.bounds.values():  # every bound the data give holds the truth
        assert bound["curvature_min"] <= -1 / 1.0001
        assert bound["concave_radius_min"] is None or bound["concave_radius_min"] <= 1.0001
    assert "indistinguishable from singular" in e.message


def test_near_singular_exact_data_is_still_resolved():
    rows = measure(sphere_plus_probes(1.0, -1.0001, 1e-4), 1.0)
    e = estimate(rows[:, :2], rows[:, 2:], 1.0)
    assert e.status == "ok"
    assert e.kx == pytest.approx(-1 / 1.0001, rel=1e-8)


@pytest.mark.parametrize("R2", [0.001, 0.002])
def test_sharper_than_sensor_gives_radius_bound_that_holds(R2):
    rows = measure(sphere_plus_probes(1.0, R2, 0.05), 1.0, resolution=0.01, sensor="array")
    e = estimate(rows[:, :2], rows[:, 2:], 1.0, resolution=0.01)
    assert e.status == "below_resolution"
    assert e.kx is None and e.k1 is None
    bound = e.bounds["k1"]["radius_max"]
    assert R2 < bound < 1.0
    assert "radius below" in e.message


def test_flatter_than_sensor_gives_flat_with_lower_radius_bound():
    rng = np.random.default_rng(3)
    rows = measure(sphere_plus_probes(1.0, 1e4, 0.5), 1.0, sigma_theta=0.01, rng=rng)
    e = estimate(rows[:, :2], rows[:, 2:], 1.0, sigma_theta=0.01)
    assert e.status == "flat"
    for key in ("k1", "k2"):
        assert 10.0 < e.bounds[key]["radius_min"] < 1e4  # true radius is above the bound
    assert np.isfinite(e.kx)


def test_plane_exact_is_flat_with_huge_bound():
    rows = measure(sphere_plus_probes(1.0, 1e300, 0.1), 1.0)
    e = estimate(rows[:, :2], rows[:, 2:], 1.0)
    assert e.status == "flat"
    assert abs(e.kx) < 1e-12
    assert e.bounds["k1"]["radius_min"] > 1e10


def test_one_direction_is_underdetermined():
    th, dp = synthetic(np.diag([0.5, 0.5]), phis=(0.0, np.pi, 0.0))
    e = estimate(th, dp, 1.0)
    assert e.status == "underdetermined"
    assert e.kx is None
    assert estimate(th[:1], dp[:1], 1.0).status == "underdetermined"


def test_indefinite_sum_is_inconsistent():
    th, dp = synthetic(np.diag([0.5, 0.5]))
    e = estimate(th, -dp, 1.0)  # contact moving the wrong way: s < 0
    assert e.status == "inconsistent"
    assert e.kx is None


def test_qr_beats_normal_equations_on_ill_conditioned_probes():
    """Nearly parallel probe directions: QR keeps accuracy the normal equations lose."""
    K2 = np.array([[0.7, 0.1], [0.1, 0.3]])
    th, dp = synthetic(K2, phis=(0.0, 1e-5, 2e-5, 3e-5))
    e = estimate(th, dp, 1.0)
    A = np.zeros((8, 3))
    a = np.column_stack([-th[:, 1], th[:, 0]])
    A[:4, :2], A[4:, 1:] = a, a
    b = np.concatenate([dp[:, 0], dp[:, 1]])
    k_ne = np.linalg.solve(A.T @ A, A.T @ b)
    S_true = np.linalg.inv(np.eye(2) + K2)
    err_qr = np.abs(np.array(e.S) - S_true).max()
    err_ne = abs(k_ne[0] - S_true[0, 0])
    assert err_qr < 1e-3 * err_ne or err_qr < 1e-6


def test_batch_equals_single_calls():
    rng = np.random.default_rng(5)
    rows = measure(
        sphere_plus_probes(1.0, np.array([0.3, 2.0, 7.0]), 0.2), 1.0, sigma_theta=0.002, rng=rng
    )
    out = estimate_batch(rows[..., :2], rows[..., 2:], 1.0, sigma_theta=0.002)
    for i in range(3):
        e = estimate(rows[i, :, :2], rows[i, :, 2:], 1.0, sigma_theta=0.002)
        args = (1.0, 0.0, 0.0, 0.002)
        tolerance.assert_point_close(e, out, i, rows[i, :, :2], rows[i, :, 2:], args)
        assert STATUSES[int(out["code"][i])] == e.status


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.tuples(*[st.floats(-1e3, 1e3, allow_nan=False)] * 4), min_size=0, max_size=9),
    st.floats(1e-3, 1e3),
)
def test_never_nan_or_inf(rows, R1):
    if not rows:
        rows = [(0.0, 0.0, 0.0, 0.0)]
    arr = np.array(rows, float)
    e = estimate(arr[:, :2], arr[:, 2:], R1, resolution=0.001)
    assert e.status in STATUSES
    for value in (e.kx, e.ky, e.k1, e.k2, e.residual):
        assert value is None or np.isfinite(value)
    for bound in e.bounds.values():
        for v in bound.values():
            if isinstance(v, float):
                assert np.isfinite(v)


def test_euler_principal_from_three_or_more_directions():
    k1, k2, phi = 1.5, -0.4, 0.3
    angles = np.array([0.0, 0.7, 1.9, 2.5])
    kn = k1 * np.cos(angles - phi) ** 2 + k2 * np.sin(angles - phi) ** 2  # eq. 64
    got = euler_principal(angles, kn)
    assert got == pytest.approx((k1, k2, phi), abs=1e-12)
    assert euler_principal([0.0, np.pi / 2], [1.0, 2.0]) is None
    assert euler_principal([0.0, np.pi, 2 * np.pi], [1.0, 1.0, 1.0]) is None


def test_two_ep1_runs_rotated_45_degrees_give_principal_curvatures_via_euler():
    """§6.2.1: kx, ky from EP1 at 0 and at 45 degrees -> four directions -> eq. 64."""
    obj = S.ellipsoid(1.5, 0.8, 1.2)
    kn, angles = [], []
    for rot in (0.0, np.pi / 4):
        phis = rot + np.array([0.0, np.pi, np.pi / 2, 1.5 * np.pi])
        _, e, truth, _ = run_ep1(obj, 1.0, 0.002, p2=(0.2, 0.3), phis=phis, sensor="exact")
        # probe directions at rot: normal curvature along the rotated axes
        c, s = np.cos(rot), np.sin(rot)
        K = np.array(e.K)
        kn += [np.array([c, s]) @ K @ [c, s], np.array([-s, c]) @ K @ [-s, c]]
        angles += [rot, rot + np.pi / 2]
    k1, k2, _ = euler_principal(angles, kn)
    assert (k1, k2) == pytest.approx((truth["k1"], truth["k2"]), rel=2e-3)


@pytest.mark.parametrize(
    ("obj", "p2"),
    [
        (S.ellipsoid(1.5, 0.8, 1.2), (0.2, 0.3)),
        (S.saddle(0.4, 0.3), (0.0, 0.0)),
        (S.paraboloid(1.0), (1.0, 0.1)),
        (S.torus(2.0, 0.7), (0.5, 0.0)),
        (S.cylinder(0.5), (0.0, 0.0)),
    ],
    ids=lambda x: getattr(x, "name", ""),
)
def test_end_to_end_on_curved_objects_converges_as_dtheta_shrinks(obj, p2):
    errs = []
    for dth in (0.04, 0.01):
        _, e, truth, _ = run_ep1(obj, 1.0, dth, p2=p2, sensor="exact")
        assert e.status in ("ok", "flat")
        errs.append(np.abs(np.array(e.K) - truth["K"]).max())
    assert errs[1] < 1e-2
    assert errs[1] < errs[0] or errs[1] < 1e-9


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.tuples(*[st.floats(-2, 2, allow_nan=False)] * 4), min_size=2, max_size=8),
    st.sampled_from([0.0, 1e-3, 0.05]),
    st.sampled_from([0.0, 1e-3]),
)
def test_scalar_path_agrees_with_batch_path(rows, resolution, sigma):
    arr = np.array(rows, float)
    e = estimate(arr[:, :2], arr[:, 2:], 1.0, resolution=resolution, sigma_theta=sigma)
    b = estimate_batch(arr[:, :2], arr[:, 2:], 1.0, resolution=resolution, sigma_theta=sigma)
    assert e.status == STATUSES[int(b["code"])]
    if e.status != "underdetermined":
        out = {k: np.asarray(v)[None] for k, v in b.items()}
        args = (1.0, 0.0, resolution, sigma)
        tolerance.assert_point_close(e, out, 0, arr[:, :2], arr[:, 2:], args)
