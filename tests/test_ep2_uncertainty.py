"""EP2 uncertainty, shrinkage and model bias: each step checked by an independent route."""

import math

import numpy as np
import pytest

from tactile.ep2 import analyze_patch, centre_result, spline, spline_answers
from tactile.ep2.geometry import shape_entries, shape_index
from tactile_sim.ep2 import make, sweep


def _scatter(n=40, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 1, n), rng.uniform(0, 1, n)


# ---- critical values -------------------------------------------------------------------


def test_crit_table_is_the_rice_quantile_envelope():
    """_CRIT[i] = max(q(0.1 i), chi2_1) with q(l) the 95 % quantile of (Rice(l) - l)^2."""
    from scipy.optimize import brentq
    from scipy.stats import rice

    def q(lam):
        def f(c):
            r = np.sqrt(c)
            if lam == 0:
                return 1 - np.exp(-c / 2) - 0.95
            return rice.cdf(lam + r, lam) - rice.cdf(max(lam - r, 0.0), lam) - 0.95

        return brentq(f, 1e-6, 50)

    for i, lam in enumerate(np.arange(0, 1.01, 0.1)):
        assert centre_result._CRIT[i] == pytest.approx(max(q(lam), 3.8415), abs=2e-3)
    assert np.all(np.diff(centre_result._CRIT) <= 0)


def test_critical_values_span_chi2_1_to_chi2_2():
    assert centre_result.critical_value(0.0) == pytest.approx(centre_result.CHI2_2_95, abs=1e-3)
    assert centre_result.critical_value(50.0) == pytest.approx(centre_result.CHI2_1_95)
    assert centre_result.critical_value_k(0.0) == pytest.approx(centre_result.CHI2_2_95, abs=2e-3)
    assert centre_result.critical_value_k(50.0) == pytest.approx(centre_result.CHI2_1_95)


# ---- tensor, Jacobian, debiasing, intervals ---------------------------------------------


def test_tensor_jacobian_matches_finite_differences():
    x, y = _scatter(seed=1)
    z = -0.3 * x * x + 0.1 * x * y - 0.2 * y * y + 0.05 * x * x * y
    fit = spline.fit_patch(x, y, z, -0.6 * x, -0.4 * y, 1.0, 1.0, 1.0)
    xs, ys = spline_answers._grid_lines(np.column_stack([x, y]), 6)
    rows = fit.grid_rows(xs, ys, first=1)
    t, G = spline_answers.tensor_and_jacobian(np.split(rows @ fit.coef, 5), rows)
    assert np.allclose(t, spline_answers._tensor(rows, fit.coef))
    h = 1e-6
    for j in range(fit.coef.size):
        dc = np.zeros(fit.coef.size)
        dc[j] = h
        tensor = spline_answers._tensor
        fd = tensor(rows, fit.coef + dc) - tensor(rows, fit.coef - dc)
        fd /= 2 * h
        assert np.allclose(G[:, j], fd, atol=1e-6)


def test_debiased_anisotropy_is_unbiased_in_h_squared():
    rng = np.random.default_rng(3)
    cov = np.diag([4e-3, 1e-3, 2e-3])
    t_true = np.array([0.5, 0.1, 0.2])
    v2 = (0.5 * (t_true[0] - t_true[2])) ** 2 + t_true[1] ** 2
    draws = rng.multivariate_normal(t_true, cov, 20000)
    h2 = np.array([centre_result.anisotropy(t, cov)[1] ** 2 for t in draws])
    plug = np.array([(0.5 * (t[0] - t[2])) ** 2 + t[1] ** 2 for t in draws])
    se = np.std(h2) / np.sqrt(h2.size)
    assert np.mean(plug) - v2 == pytest.approx(0.25 * (4e-3 + 2e-3) + 1e-3, abs=4 * se)
    assert abs(np.mean(h2) - v2) < 4 * se


def test_k1_interval_is_the_delta_method_far_from_umbilics():
    t = np.array([0.4, 0.05, 0.02])
    cov = 1e-6 * np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.0], [0.1, 0.0, 1.5]])
    m, h, lam = centre_result.anisotropy(t, cov)
    iv = centre_result.ellipsoid_intervals(t, cov, m, h, lam)
    d = np.array([0.5 * (t[0] - t[2]), t[1]]) / np.hypot(0.5 * (t[0] - t[2]), t[1])
    grad = np.array([0.5 + 0.5 * d[0], d[1], 0.5 - 0.5 * d[0]])  # d(m + h)/d(a, b, c)
    half = 1.96 * np.sqrt(grad @ cov @ grad)
    lo, hi = iv.k1
    assert lo == pytest.approx(m + h - half, abs=0.02 * half)
    assert hi == pytest.approx(m + h + half, abs=0.02 * half)


@pytest.mark.parametrize(
    "t_true, key, truth",
    [
        ((0.4, 0.0, 0.4), "S", 1.0),  # sphere: S = 1 sits on the boundary of S's range
        ((0.4, 0.0, 0.4), "k2", 0.4),  # sphere: k2 at the cone's vertex
        ((0.4, 0.0, 0.4), "k1", 0.4),
        ((0.4, 0.0, 0.0), "S", 0.5),  # cylinder: smooth case
        ((0.4, 0.0, 0.0), "k1", 0.4),
    ],
)
def test_interval_coverage_on_gaussian_tensors(t_true, key, truth):
    """The ellipsoid projection covers the truth ~95 % when t_hat ~ N(t, Cov) exactly."""
    rng = np.random.default_rng(5)
    cov = 1e-4 * np.array([[1.0, 0.2, 0.1], [0.2, 0.6, 0.0], [0.1, 0.0, 0.8]])
    hits = 0
    n = 600
    for t in rng.multivariate_normal(t_true, cov, n):
        m, h, lam = centre_result.anisotropy(t, cov)
        lo, hi = getattr(centre_result.ellipsoid_intervals(t, cov, m, h, lam), key)
        hits += lo <= truth <= hi
    assert 0.92 <= hits / n <= 0.995  # k at the umbilic vertex is conservative (~0.99)


# ---- shrinkage toward the 2-jet ------------------------------------------------------


@pytest.mark.parametrize("degree, segments", [((2, 2), (1, 1)), ((3, 2), (1, 1)), ((2, 2), (2, 2))])
def test_jet_span_reproduces_the_monomials(degree, segments):
    tx = spline.knots(degree[0], segments[0])
    ty = spline.knots(degree[1], segments[1])
    Q = spline.jet_span(*degree, tx, ty)
    u, v = _scatter(seed=7)
    rows = spline.rowwise_kron(spline.basis(u, degree[0], tx), spline.basis(v, degree[1], ty))
    mono = np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])
    assert np.allclose(rows @ Q, mono, atol=1e-12)


def _fit(z, zx, zy, x, y, seed=None, noise=0.0):
    if seed is not None:
        rng = np.random.default_rng(seed)
        z, zx, zy = (a + noise * rng.standard_normal(a.size) for a in (z, zx, zy))
    domain, rows = spline.prepare(x, y)
    f = spline.fit_patch(x, y, z, zx, zy, 1.0, 1.0, 1.0, domain=domain, rows=rows)
    return f, rows, (z, zx, zy)


def test_shrinkage_keeps_clean_excess_and_drops_pure_noise():
    x, y = _scatter(seed=2)
    # clean surface with a strong x^2 y^2 term: the excess is significant, w -> 1
    z = -0.2 * x * x + x * x * y * y
    zx, zy = -0.4 * x + 2 * x * y * y, 2 * x * x * y
    f, rows, data = _fit(z, zx, zy, x, y, seed=1, noise=1e-4)
    s2 = f.chi2 / f.dof
    g, w, d2 = spline.shrink_to_jet(f, *data, s2, rows)
    assert w > 0.999 and d2 > 1e3
    # a quadric plus noise: most trials shrink the excess strongly
    zq, zqx, zqy = -0.2 * x * x + 0.1 * y * y, -0.4 * x, 0.2 * y
    ws = []
    for seed in range(20):
        f, rows, data = _fit(zq, zqx, zqy, x, y, seed=seed, noise=1e-2)
        ws.append(spline.shrink_to_jet(f, *data, f.chi2 / f.dof, rows)[1])
    assert np.median(ws) < 0.3


def test_shrunk_covariance_and_data_map_are_the_linear_maps():
    x, y = _scatter(seed=4)
    z = -0.3 * x * x + 0.2 * x * x * y
    f, rows, data = _fit(z, -0.6 * x + 0.4 * x * y, 0.2 * x * x, x, y, seed=3, noise=0.02)
    g, w, _ = spline.shrink_to_jet(f, *data, f.chi2 / f.dof, rows)
    assert 0.0 < w < 1.0
    Q = spline.jet_span(2, 2, f.tx, f.ty)
    R = np.linalg.inv(f.cov_factor)
    P = Q @ np.linalg.pinv(R @ Q) @ R  # projection onto the jet span (precision metric)
    S = (1 - w) * P + w * np.eye(9)
    assert np.allclose(g.coef, S @ f.coef)
    cov_f = f.cov_factor @ f.cov_factor.T
    assert np.allclose(g.cov_factor @ g.cov_factor.T, S @ cov_f @ S.T, atol=1e-10)
    stacked = np.concatenate(data)
    assert np.allclose(f.data_map @ stacked, f.coef)
    assert np.allclose(g.data_map @ stacked, g.coef)


# ---- fit extras: leverage, grid rows, noise estimate ---------------------------------


def test_leverage_is_the_hat_diagonal_and_grid_rows_match_rows():
    x, y = _scatter(seed=6)
    z = -0.3 * x * x
    w = (2.0, 0.5, 0.7)
    for solver in ("svd", "qr", "gelsy"):
        f = spline.fit_patch(x, y, z, -0.6 * x, 0 * y, *w, solver=solver)
        a0, a1, a2 = spline.design(x, y, f.domain, f.degree, f.tx, f.ty)
        A = np.vstack([w[0] * a0, w[1] * a1, w[2] * a2])
        hat = A @ np.linalg.solve(A.T @ A, A.T)
        assert np.allclose(f.leverage, np.diag(hat), atol=1e-10)
        assert f.leverage.sum() == pytest.approx(9.0)
    xs, ys = np.linspace(0, 1, 5), np.linspace(0.1, 0.9, 4)
    gx, gy = (g.ravel() for g in np.meshgrid(xs, ys, indexing="ij"))
    assert np.allclose(f.grid_rows(xs, ys, first=1), f.rows(gx, gy, first=1))


@pytest.mark.parametrize("method", ["jet", "spline"])
def test_noise_per_row_type_is_estimated(method):
    """A quadric height field (no model misfit in the residuals), position noise 0.02 and
    normal noise 0.005: both sigmas recovered within 15 %.  (Position noise along the
    surface also moves where a slope is read, adding |k| sigma_pos = 0.002 to the slope
    noise - 8 % here, 3x when sigma_normal is 0.001: the estimate then rightly grows.)"""
    obj = make("quadric", k=(0.1, 0.04), rotation_deg=30.0)
    ratios = []
    for seed in range(12):
        d = sweep(obj, noise_pos=0.02, noise_normal=0.005, seed=seed)
        res = analyze_patch(d["points"], d["normals"], method=method)
        # z noise of a 3-D position error is sigma (sqrt(1+g^2) is in the weights)
        ratios.append((res.noise_pos / 0.02, res.noise_normal / 0.005))
    r = np.median(ratios, axis=0)
    assert r[0] == pytest.approx(1.0, abs=0.15)
    assert r[1] == pytest.approx(1.0, abs=0.15)


# ---- model bias -------------------------------------------------------------------------


def test_constant_curvature_data_is_a_sphere_to_fourth_order():
    k = 0.25
    rng = np.random.default_rng(0)
    xy = rng.uniform(-0.3, 0.3, (30, 2))
    z, zx, zy = spline_answers.constant_curvature_data(xy, np.zeros(2), (k, 0.0, k))
    r2 = np.sum(xy**2, axis=1)
    cap = -r2 / (np.sqrt(1 / k**2 - r2) + 1 / k)  # exact sphere of radius 1/k
    assert np.max(np.abs(z - cap)) < 2 * k**5 * np.max(r2) ** 3  # O(r^6) remainder
    root = np.sqrt(1 / k**2 - r2)
    assert np.allclose(zx, -xy[:, 0] / root, atol=4 * k**5 * np.max(r2) ** 2.5)
    assert np.allclose(zy, -xy[:, 1] / root, atol=4 * k**5 * np.max(r2) ** 2.5)


def test_model_bias_predicts_the_fit_bias_on_clean_circles(monkeypatch):
    """Noise-free cylinder R 8 and sphere R 10, the thesis's spline: the refit bias of the
    mean curvature matches the actual error at the patch centre within 25 % (there the
    biquadratic overestimates the curvature; over the whole grid it underestimates)."""
    orig = spline_answers.model_bias
    seen = {}

    def spy(fit, xy, centre, tensor, grid_tensor):
        seen["b"] = orig(fit, xy, centre, tensor, grid_tensor)
        seen["t"] = tensor
        return seen["b"]

    monkeypatch.setattr(spline_answers, "model_bias", spy)
    for kind, radius in (("cylinder", 8.0), ("sphere", 10.0)):
        d = sweep(make(kind, radius, 25.0))
        res = analyze_patch(d["points"], d["normals"], method="spline")
        m_true = 0.5 * sum(make(kind, radius).true_k())
        m_err = 0.5 * (seen["t"][0] + seen["t"][2]) / res.scale - m_true
        m_bias = 0.5 * (seen["b"][0] + seen["b"][2]) / res.scale
        assert abs(m_err) > 1e-4 and m_bias == pytest.approx(m_err, rel=0.25)


# ---- end to end: calibration where the first pass failed --------------------------------


def test_tight_cylinder_k1_interval_covers_despite_model_bias():
    """R 8 at noise 0.005: the noise-only interval covered 1/8 in 26-32 % of trials."""
    hits = 0
    for seed in range(30):
        d = sweep(make("cylinder", 8.0, 25.0), noise_pos=0.005, noise_normal=0.005, seed=seed)
        lo, hi = analyze_patch(d["points"], d["normals"]).k1_interval
        hits += lo <= 1 / 8 <= hi
    assert hits >= 27


def test_sphere_s_interval_covers_one_and_no_other_shape_is_named():
    hits = 0
    for seed in range(30):
        d = sweep(make("sphere", 10.0, 25.0), noise_pos=0.02, noise_normal=0.02, seed=seed)
        res = analyze_patch(d["points"], d["normals"])
        lo, hi = res.S_interval
        hits += lo <= 1.0 <= hi
        assert res.shape in ("sphere", "uncertain")
        assert max(res.votes, key=res.votes.get) == "sphere"
    assert hits >= 26  # the first pass covered 76-80 %


def test_partly_stated_noise_estimates_the_rest():
    d = sweep(make("sphere", 10.0), noise_pos=0.01, noise_normal=0.01, seed=3)
    res = analyze_patch(d["points"], d["normals"], noise_pos=0.01)
    assert res.shape == "sphere"
    assert res.S_interval[1] - res.S_interval[0] < 0.2
    full = analyze_patch(d["points"], d["normals"], noise_pos=0.01, noise_normal=0.01)
    assert res.k1 == pytest.approx(full.k1, rel=0.02)


@pytest.mark.parametrize("method", ["jet", "spline"])
def test_shape_index_of_k1_k2_is_s(method):
    d = sweep(make("cylinder", 9.0, 40.0), noise_pos=0.01, noise_normal=0.01, seed=8)
    res = analyze_patch(d["points"], d["normals"], method=method)
    assert res.S == pytest.approx(float(shape_index(res.k1, res.k2)), abs=1e-12)
    a, b, c = shape_entries(0.0, 0.0, -1.0, 0.0, 0.0)
    assert (a, b, c) == (1.0, 0.0, 0.0)  # convex toward +z is positive (sign convention)


# ---- labels from asymmetric S intervals ---------------------------------------------------


def test_split_normal_vote_respects_a_one_sided_interval():
    from tactile.ep2 import centre_result

    # symmetric: the split normal is the normal
    for x in (-0.3, 0.1, 0.45, 0.9):
        ref = 0.5 * math.erfc(-(x - 0.4) / (0.2 * math.sqrt(2)))
        assert centre_result.split_normal_cdf(x, 0.4, 0.2, 0.2) == pytest.approx(ref)
    assert centre_result.split_normal_cdf(10.0, 0.4, 0.1, 0.3) == pytest.approx(1.0)
    # the case that gave a confident "sphere" for a barely curved cylinder (R 200, noise
    # 0.02, seed 1182): debiased S = 1 with its 95 % interval (0.536, 1)
    root = math.sqrt(centre_result.CHI2_2_95)
    label, conf, _ = centre_result.vote(1.0, ((1.0 - 0.536) / root, 0.0))
    assert label == "uncertain" and conf < 0.9
    d = sweep(make("cylinder", 200.0, 25.0), noise_pos=0.02, noise_normal=0.02, seed=1182)
    assert analyze_patch(d["points"], d["normals"]).shape in ("cylinder", "plane", "uncertain")
