"""EP1: ``estimate`` (one point, plain floats) equals ``estimate_batch`` (NumPy QR) point by
point on random mixtures of ordinary and degenerate probe sets (eqs. 29-33)."""

import numpy as np
import pytest
import tolerance

from tactile.ep1.estimator import STATUSES, estimate, estimate_batch
from tactile_sim.ep1.probes import measure, sphere_plus_probes

KINDS = (
    "random",
    "zero_displacement",
    "below_resolution",
    "near_singular",
    "nearly_parallel",
    "one_direction",
    "zero_rotation",
    "plane",
    "inconsistent",
    "sharp",
)


def _point(kind, m, R1, u0, resolution, rng):
    """One (m, 4) probe set of the given kind: rows dtheta_x, dtheta_y, du, dv."""
    phis = rng.uniform(0, 2 * np.pi, m)
    dth = 10 ** rng.uniform(-2, 0)
    if kind == "nearly_parallel":  # condition number ~1e3
        phis = phis[0] + 1e-3 * rng.uniform(-1, 1, m)
    th = dth * np.column_stack([np.cos(phis), np.sin(phis)])
    S = rng.normal(size=(2, 2))
    S = R1 * (np.eye(2) + 0.3 * (S + S.T))  # (K1 + K2~)^-1 near R1: mostly positive definite
    noise = 0.0 if kind == "nearly_parallel" else dth * 10 ** rng.uniform(-8, -2)
    if kind == "plane":
        S = R1 * np.eye(2)
    elif kind == "inconsistent":
        S = -S
    elif kind == "sharp":  # object much smaller than the finger: tiny displacements
        S = 1e-6 * S
    elif kind == "one_direction":
        th = np.outer(rng.normal(size=m), [np.cos(phis[0]), np.sin(phis[0])])
    elif kind == "zero_rotation":
        th[:] = 0.0
    elif kind == "near_singular":  # concave sphere just larger than the finger, noisy
        rows = measure(sphere_plus_probes(R1, -1.0001 * R1, 1e-4), R1, 1e-4, rng=rng)
        return rows[rng.integers(0, len(rows), m)]
    b = np.column_stack([-th[:, 1], th[:, 0]]) @ S.T + rng.normal(size=(m, 2)) * noise * R1
    dp = b / [R1, R1 * np.cos(u0)]  # eq. 29 with the metric M1 of eq. 20
    if kind == "zero_displacement":
        dp[:] = 0.0
    elif kind == "below_resolution":
        dp = rng.uniform(-0.3, 0.3, (m, 2)) * (resolution or 1e-3 * R1) / R1
    return np.column_stack([th, dp])


def test_single_equals_batch_on_random_and_degenerate_points():
    """Six sensor configurations x 200 points of every kind: same status, same numbers."""
    seen = set()
    for seed in range(6):
        rng = np.random.default_rng(seed)
        m = int(rng.integers(2, 10))
        R1 = 10 ** rng.uniform(-2, 2)
        u0 = (0.0, 0.4)[seed % 2]
        resolution = (0.0, 1e-4 * R1, 1e-2 * R1)[seed % 3]
        sigma = (0.0, 1e-3)[seed // 3]
        kinds = [KINDS[i % len(KINDS)] for i in range(200)]
        rows = np.array([_point(k, m, R1, u0, resolution, rng) for k in kinds])
        out = estimate_batch(rows[..., :2], rows[..., 2:], R1, u0, resolution, sigma)
        for i, kind in enumerate(kinds):
            e = estimate(rows[i, :, :2], rows[i, :, 2:], R1, u0, resolution, sigma)
            assert e.status == STATUSES[out["code"][i]], (seed, kind, e)
            assert e.n_probes == m
            seen.add(e.status)
            if e.status == "underdetermined":
                assert e.kx is None and e.S == [[0.0, 0.0], [0.0, 0.0]]
            else:
                args = (R1, u0, resolution, sigma)
                tolerance.assert_point_close(e, out, i, rows[i, :, :2], rows[i, :, 2:], args)
    assert seen == set(STATUSES)


@pytest.mark.parametrize("m", [0, 1])
def test_fewer_than_two_probes_are_underdetermined_on_both_paths(m):
    rows = np.random.default_rng(m).normal(size=(5, m, 4))
    out = estimate_batch(rows[..., :2], rows[..., 2:], 1.0)
    assert list(out["code"]) == [STATUSES.index("underdetermined")] * 5
    for point in rows:
        assert estimate(point[:, :2], point[:, 2:], 1.0).status == "underdetermined"


def test_single_point_rejects_mismatched_probe_counts():
    with pytest.raises(ValueError, match="dtheta has 3 probes but dp has 2"):
        estimate(np.ones((3, 2)), np.ones((2, 2)), 1.0)


@pytest.mark.parametrize(("k", "c"), [(0, 400), (0, -400), (400, 0), (-20, -300), (900, 0)])
def test_one_point_at_extreme_magnitudes_scales_by_powers_of_two(k, c):
    """dtheta, dp x 2^k and R1 x 2^c leave the geometry alone (S x 2^c, curvature x 2^-c,
    residual x 2^(k + c)): data near under/overflow are rescaled exactly inside."""
    rows = measure(sphere_plus_probes(1.0, 0.7, 0.3), 1.0, 1e-3, rng=np.random.default_rng(1))
    th, dp = rows[:, :2], rows[:, 2:]
    e0 = estimate(th, dp, 1.0)
    e1 = estimate(np.ldexp(th, k), np.ldexp(dp, k), np.ldexp(1.0, c))
    assert e0.status == e1.status == "ok"
    np.testing.assert_allclose(np.ldexp(e1.S, -c), e0.S, rtol=1e-15)
    for field in ("kx", "ky", "k1", "k2"):
        assert np.ldexp(getattr(e1, field), c) == pytest.approx(getattr(e0, field), rel=1e-14)
    assert np.ldexp(e1.residual, -c - k) == pytest.approx(e0.residual, rel=1e-14)
