"""Independent checks of the EP2 jet's building blocks, each against a route it shares nothing with.

Guards:
- ``jet_basis.round_excess`` + the quadric IS a sphere / a cylinder of any axis (and their
  concave twins): height and slopes against z = -(R - sqrt(R^2 - r^2)) written out by hand;
- ``round_jacobian``, ``round_second`` and ``round_excess``'s own slopes against central
  finite differences;
- ``design``: derivative rows against finite differences of the position rows, and its
  coefficients are the partial derivatives at the centre (``CHANNELS``, ``HESSIAN``);
- ``batch_lstsq.solve`` against ``numpy.linalg.lstsq`` (coef, hat diagonal, rss), zero-weight
  rows, and the documented minimum-norm answer and rank of a rank-deficient problem; a
  problem with non-finite or overflowing numbers gets NaN alone, the caller's A untouched;
- ``jet_rows.whitened_design`` and ``geometry`` against the design matrix whitened and
  multiplied out (their fast forms share nothing with ``design``);
- ``centre_result.widen(nu)`` = q F_q,nu(0.95) / chi2_q(0.95) from ``scipy.stats``, -> 1.
"""

import math

import numpy as np
import pytest
from scipy import stats

from tactile.ep2 import batch_lstsq, centre_result, jet_basis, jet_rows


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


def test_round_valid_and_max_q2_follow_the_rim():
    """Q2 = |H d|^2: a sphere of curvature k reaches the rim at r = 1/k."""
    H = -0.5 * np.eye(2)
    x = np.array([0.0, 1.0, 1.999])
    y = np.zeros(3)
    assert jet_basis.max_q2(x, y, H, np.ones(3, bool)) == pytest.approx(0.25 * 1.999**2)
    assert not jet_basis.round_valid(x, y, H, np.ones(3, bool))  # 0.999 at r = 1.999
    assert jet_basis.round_valid(x, y, H, np.array([True, True, False]))  # masked out


# --- derivatives against finite differences ----------------------------------------------


def _random_H(rng):
    a, b, c = rng.uniform(-0.6, 0.6, 3)
    return np.array([[a, b], [b, c]])


@pytest.mark.parametrize("seed", range(5))
def test_round_jacobian_matches_central_differences(seed):
    rng = _rng(200 + seed)
    H = _random_H(rng)
    x, y = _inside_disc(rng, 30, 0.9 / max(np.abs(np.linalg.eigvalsh(H)).max(), 1e-3))
    J = jet_basis.round_jacobian(x, y, H)
    assert J.shape == (90, 3)
    h = 1e-6
    for k, cells in enumerate((((0, 0),), ((0, 1), (1, 0)), ((1, 1),))):
        step = np.zeros((2, 2))
        for cell in cells:
            step[cell] = h
        fd = (jet_basis.round_rows(x, y, H + step) - jet_basis.round_rows(x, y, H - step)) / (2 * h)
        np.testing.assert_allclose(J[:, k], fd, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("seed", range(5))
def test_round_jacobian_in_closed_form_matches_complex_steps(seed):
    """The chain-rule Jacobian against an independent route exact to round-off: one complex
    step per Hessian entry through ``round_excess`` (what the Jacobian was before)."""
    rng = _rng(250 + seed)
    H = _random_H(rng)
    x, y = _inside_disc(rng, 30, 0.95 / max(np.abs(np.linalg.eigvalsh(H)).max(), 1e-3))
    rows, J = jet_basis.round_rows_jacobian(x, y, H)
    np.testing.assert_allclose(rows, jet_basis.round_rows(x, y, H), rtol=1e-14, atol=1e-15)
    h = 1e-30
    for k, cells in enumerate((((0, 0),), ((0, 1), (1, 0)), ((1, 1),))):
        Hc = H.astype(complex)
        for cell in cells:
            Hc[cell] += 1j * h
        cs = jet_basis.round_rows(x.astype(complex), y.astype(complex), Hc).imag / h
        np.testing.assert_allclose(J[:, k], cs, rtol=1e-12, atol=1e-14)


def test_round_jacobian_is_zero_in_q2_past_the_rim_and_broadcasts():
    """Past the rim Q2 is clamped: the rows stop moving with Q2; a batch equals each alone."""
    H = np.array([[[-1.0, 0.0], [0.0, -1.0]], [[-0.3, 0.1], [0.1, 0.2]]])
    x = np.array([[0.5, 1.2, 0.0], [0.4, -0.8, 1.1]])
    y = np.array([[0.0, 0.3, 0.9], [0.2, 0.5, -0.6]])
    rows, J = jet_basis.round_rows_jacobian(x, y, H)
    assert J.shape == (2, 9, 3) and np.all(np.isfinite(J))
    for b in range(2):
        one = jet_basis.round_rows_jacobian(x[b], y[b], H[b])
        np.testing.assert_allclose(J[b], one[1], rtol=1e-15)
    # the sphere's second contact is past the rim (Q2 = 1.53): its z row depends on H only
    # through Q1 there
    np.testing.assert_allclose(
        J[0, 1],
        np.array([x[0, 1] ** 2, 2 * x[0, 1] * y[0, 1], y[0, 1] ** 2])
        * (1 / (1 + np.sqrt(1 - 0.999)) - 0.5),
        rtol=1e-12,
    )


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


# --- batch least squares -----------------------------------------------------------------


def _problem(rng, B=4, m=30, p=6):
    A = rng.normal(size=(B, m, p)) * 10.0 ** rng.uniform(-3, 3, (B, 1, p))  # unequal columns
    b = rng.normal(size=(B, m))
    w = rng.uniform(0.1, 10.0, (B, m))
    return A, b, w


def test_solve_matches_numpy_lstsq_on_weighted_full_rank_problems():
    rng = _rng(11)
    A, b, w = _problem(rng)
    sol = batch_lstsq.solve(A, b, w)
    for k in range(len(A)):
        Aw, bw = A[k] * w[k][:, None], b[k] * w[k]
        coef, res, rank, _ = np.linalg.lstsq(Aw, bw, rcond=None)
        np.testing.assert_allclose(sol.coef[k], coef, rtol=1e-9, atol=1e-12 * np.abs(coef).max())
        assert sol.rank[k] == rank == A.shape[2]
        assert sol.rss[k] == pytest.approx(res[0], rel=1e-9)
        hat = Aw @ np.linalg.solve(Aw.T @ Aw, Aw.T)
        np.testing.assert_allclose(sol.leverage[k], np.diag(hat), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(sol.residual[k], bw - Aw @ coef, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(sol.pinv[k] @ Aw, np.eye(A.shape[2]), atol=1e-9)
    assert sol.leverage.sum(axis=1) == pytest.approx(np.full(len(A), A.shape[2]))


def test_zero_weight_rows_change_nothing():
    rng = _rng(12)
    A, b, w = _problem(rng)
    base = batch_lstsq.solve(A, b, w)
    extra = 7
    A2 = np.concatenate([A, 1e3 * rng.normal(size=(A.shape[0], extra, A.shape[2]))], axis=1)
    b2 = np.concatenate([b, 1e3 * rng.normal(size=(A.shape[0], extra))], axis=1)
    w2 = np.concatenate([w, np.zeros((A.shape[0], extra))], axis=1)
    # shuffle the padding in among the real rows
    order = rng.permutation(A2.shape[1])
    pad = np.sort(np.flatnonzero(order >= A.shape[1]))
    sol = batch_lstsq.solve(A2[:, order], b2[:, order], w2[:, order])
    np.testing.assert_allclose(sol.coef, base.coef, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(sol.rss, base.rss, rtol=1e-10)
    np.testing.assert_array_equal(sol.rank, base.rank)
    assert np.all(sol.leverage[:, pad] == 0) and np.all(sol.residual[:, pad] == 0)
    keep = np.argsort(order)[: A.shape[1]]
    np.testing.assert_allclose(sol.leverage[:, keep], base.leverage, rtol=1e-10, atol=1e-14)


def test_rank_deficient_problem_gives_the_minimum_norm_solution_and_its_rank():
    """Two columns carry the same direction: rank p - 1.  The module promises the
    minimum-norm solution in unit-norm columns: pinv of the column-scaled matrix."""
    rng = _rng(13)
    A, b, w = _problem(rng, B=3)
    A[:, :, 4] = -3.0 * A[:, :, 1]
    A[2, :, 5] = 0.0  # and a zero column in one problem: rank p - 2 there
    sol = batch_lstsq.solve(A, b, w)
    np.testing.assert_array_equal(sol.rank, [5, 5, 4])
    for k in range(3):
        Aw, bw = A[k] * w[k][:, None], b[k] * w[k]
        norms = np.linalg.norm(Aw, axis=0)
        norms[norms == 0] = 1.0
        want = np.linalg.pinv(Aw / norms, rcond=1e-10) @ bw / norms
        np.testing.assert_allclose(sol.coef[k], want, rtol=1e-8, atol=1e-12 * np.abs(want).max())
        _, res, rank, _ = np.linalg.lstsq(Aw, bw, rcond=None)
        assert rank == sol.rank[k]
        ref = np.linalg.lstsq(Aw, bw, rcond=None)[0]
        assert sol.rss[k] == pytest.approx(np.sum((bw - Aw @ ref) ** 2), rel=1e-9)
        # minimum norm: orthogonal (in scaled units) to the null vector of the repeated column
        null = np.zeros(A.shape[2])
        null[1], null[4] = 3.0 * norms[1], norms[4]
        np.testing.assert_allclose((Aw / norms) @ null, 0.0, atol=1e-9 * np.abs(Aw).max())
        assert abs(np.dot(sol.coef[k] * norms, null)) < 1e-9 * np.linalg.norm(
            null
        ) * np.linalg.norm(sol.coef[k] * norms)
        if k == 2:
            assert sol.coef[k, 5] == 0.0  # the zero column gets nothing
        assert sol.leverage[k].sum() == pytest.approx(sol.rank[k])


def test_non_finite_or_overflowing_problem_gets_nan_alone_and_the_input_is_untouched():
    """A NaN in A, and entries past 1e154 (A^T A overflows), determine nothing: NaN
    coefficients, rank 0; the other problems equal their solves alone; A as passed (a
    transposed view, the layout ``jet_rows`` hands over) is not written to."""
    rng = _rng(21)
    A, b, w = _problem(rng, B=4, m=30, p=6)
    A[1, 3, 2] = np.nan
    A[2] *= 1e160
    At = np.ascontiguousarray(np.swapaxes(A, 1, 2))
    view = np.swapaxes(At, 1, 2)
    before = At.copy()
    sol = batch_lstsq.solve(view, b, w)
    np.testing.assert_array_equal(At, before)
    assert np.isnan(sol.coef[[1, 2]]).all() and list(sol.rank[[1, 2]]) == [0, 0]
    for k in (0, 3):
        alone = batch_lstsq.solve(A[k : k + 1], b[k : k + 1], w[k : k + 1])
        np.testing.assert_allclose(sol.coef[k], alone.coef[0], rtol=1e-12)
        assert sol.rank[k] == 6


@pytest.mark.parametrize("part", ["all", "pos", "slopes"])
@pytest.mark.parametrize("order", [2, 3, 4])
def test_whitened_design_and_geometry_equal_the_design_multiplied_out(order, part):
    """``whitened_design`` = each contact's 3 x 3 T times its rows of ``design`` (written
    out with einsum), keeping ``part``'s blocks; ``geometry`` = the derivative rows of
    ``design`` times coef."""
    rng = _rng(30 + order)
    B, n = 5, 12
    x, y = rng.uniform(-3, 3, (2, B, n))
    T = np.tril(rng.normal(size=(B, n, 3, 3)))
    first, stop = jet_rows.PARTS[part]
    T[:, :, :first] = T[:, :, :, :first] = T[:, :, stop:] = T[:, :, :, stop:] = 0.0
    D = jet_basis.design(x, y, order).reshape(B, 3, n, -1)
    full = np.einsum("bnkl,blnp->bknp", T, D)[:, first:stop].reshape(B, -1, D.shape[-1])
    got = jet_rows.whitened_design(x, y, order, T, part)
    np.testing.assert_allclose(got, full, rtol=1e-13, atol=1e-13 * np.abs(full).max())
    coef = rng.normal(size=(B, jet_basis.n_coef(order)))
    derivs = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    v = np.einsum("bmp,bp->bm", jet_basis.design(x, y, order, derivs), coef).reshape(B, 5, n)
    g, h = jet_rows.geometry(
        jet_rows.positions(np.stack([x, y, x], -1), np.ones((B, n), bool)), coef
    )
    np.testing.assert_allclose(
        np.concatenate([g, h], -1), np.moveaxis(v, 1, -1), rtol=1e-12, atol=1e-12 * np.abs(v).max()
    )


def test_fast_path_and_svd_path_agree_and_each_problem_takes_its_own_path(monkeypatch):
    """CholeskyQR2 (well conditioned, a zero column included) equals the SVD path to
    round-off; a problem conditioned past ``FAST_MAX_COND``, a rank-deficient one and one
    with fewer rows than columns go to the SVD without changing the others."""
    rng = _rng(14)
    A, b, w = _problem(rng, B=6, m=30, p=6)
    A[1, :, 3] = 0.0  # a dead column: fast path, coefficient 0, blind there
    A[2, :, 2] = A[2, :, 0] * (1 + 1e-7 * rng.normal(size=30))  # cond ~1e7: SVD
    A[3, :, 5] = A[3, :, 4]  # rank 5: SVD
    w[4, 4:] = 0.0  # 4 rows for 6 columns: SVD, rank 4
    X = A * w[..., None]
    X = X / np.where((n := np.linalg.norm(X, axis=1)) > 0, n, 1.0)[:, None, :]
    Xt, live = np.swapaxes(X, 1, 2).copy(), np.linalg.norm(X, axis=1) > 0
    *_, fast = batch_lstsq._cholesky_qr2(Xt, Xt @ X, np.ones((6, 6)), live)
    np.testing.assert_array_equal(fast, [True, True, False, False, False, True])
    mixed = batch_lstsq.solve(A, b, w)
    monkeypatch.setattr(batch_lstsq, "FAST_MAX_COND", 0.0)  # everything through the SVD
    svd = batch_lstsq.solve(A, b, w)
    np.testing.assert_array_equal(mixed.rank, [6, 5, 6, 5, 4, 6])
    np.testing.assert_array_equal(mixed.rank, svd.rank)
    for k in (0, 1, 3, 4, 5):  # problem 2: its cond amplifies round-off
        c = np.abs(svd.coef[k]).max()
        np.testing.assert_allclose(mixed.coef[k], svd.coef[k], rtol=1e-9, atol=1e-12 * c)
        np.testing.assert_allclose(mixed.leverage[k], svd.leverage[k], atol=1e-12)
        np.testing.assert_allclose(mixed.blind[k], svd.blind[k], atol=1e-12)
        p_scale = np.abs(svd.pinv[k]).max()
        np.testing.assert_allclose(mixed.pinv[k], svd.pinv[k], atol=1e-10 * p_scale)
    assert mixed.coef[1, 3] == 0.0 and mixed.blind[1, 3, 3] == 1.0


@pytest.mark.parametrize("B", [batch_lstsq.SMALL_STACK - 1, 3 * batch_lstsq.SMALL_STACK])
def test_upper_inverse_is_each_problems_inverse_whatever_the_stack(B):
    """Both branches (LAPACK below ``SMALL_STACK``, back substitution over the stack above):
    R^-1 R = I to round-off times cond, nothing below the diagonal, and a problem's inverse
    the same to round-off whether the rest of the stack is there or not."""
    rng = _rng(15)
    p = 10
    R = np.triu(rng.normal(size=(B, p, p)))
    R[:, np.arange(p), np.arange(p)] = np.abs(R[:, np.arange(p), np.arange(p)]) + 0.1
    R[0] *= np.logspace(0, 6, p)[:, None]  # rows scaled over 6 decades: cond ~1e6
    inv = batch_lstsq._upper_inverse(R)
    assert np.all(np.tril(inv, -1) == 0.0)
    for k in range(B):
        cond = np.linalg.cond(R[k])
        err = np.abs(inv[k] @ R[k] - np.eye(p)).max()
        assert err < 1e-14 * cond, (k, err, cond)
    alone = np.linalg.inv(R[:1])[0]
    tol = 1e-14 * np.linalg.cond(R[0]) * np.abs(alone).max()
    np.testing.assert_allclose(inv[0], alone, rtol=0, atol=tol)


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
