"""Work the centre jet leaves out is work nobody reads (issue 13, "compute only what a run
uses"): without intervals the truncation views are not fitted; the one-row-type fits run
the round model only on the patches whose result or misfit it can change.  Either way
every field that is read comes out the same."""

import numpy as np
import pytest

from tactile.ep2 import centre_jet, jet_models, jet_rows
from tactile_sim.ep2 import make, sweep

FIELDS = ("t", "cov", "cov_noise", "dof", "model", "chi2", "score", "coef", "noise", "weight")


def _stack(kind, radius, noise, n=24):
    ds = [
        sweep(make(kind, radius, 20.0), noise_pos=noise, noise_normal=noise, seed=s)
        for s in range(n)
    ]
    P = np.array([d["points"] for d in ds])
    N = np.array([d["normals"] for d in ds])
    return P, N, np.ones(P.shape[:2], bool)


@pytest.mark.parametrize("kind,radius,noise", [("cylinder", 10.0, 0.01), ("sphere", 8.0, 5e-4)])
def test_without_intervals_the_truncation_views_are_skipped_and_nothing_else_moves(
    mocker, kind, radius, noise
):
    P, N, mask = _stack(kind, radius, noise)
    full = centre_jet.fit(P, N, mask)
    views = mocker.spy(centre_jet, "_next_order")
    truncation = mocker.spy(centre_jet, "_truncation")
    bare = centre_jet.fit(P, N, mask, intervals=False)
    assert views.call_count == 0 and truncation.call_count == 0
    for key in FIELDS:
        np.testing.assert_array_equal(getattr(bare, key), getattr(full, key), err_msg=key)
    for a, b in zip(bare.split, full.split, strict=True):
        for x, y in zip(a[:2], b[:2], strict=True):
            np.testing.assert_array_equal(x, y)


def _split_round_of_all(rows, mask, quad, fits):
    """The reference: the round model fitted to every patch, the lower chi^2's misfit."""
    dof = np.maximum(rows.w.sum(axis=1) - quad.rank, 1)
    start = np.where((fits.model == 1)[:, None], fits.coef[:, : quad.coef.shape[1]], quad.coef)
    rnd = jet_models.round_model(rows, mask, start, centre_jet.SPLIT_TOL)
    best = np.minimum(quad.rss, np.where(rnd.ok, rnd.sol.rss, np.inf))
    pick = ((fits.model == 1) & rnd.ok)[:, None]
    return np.where(pick, rnd.sol.coef, quad.coef), np.maximum(best / dof, 1.0), rnd


@pytest.mark.parametrize("part", ["pos", "slopes"])
def test_the_round_split_fit_on_the_patches_that_need_it_equals_it_on_all(mocker, part):
    """Cylinders (the quadric chosen, about half the chi^2 / dof above 1) mixed with spheres
    at low noise (the round model chosen): the same coefficients and misfit as fitting the
    round model everywhere, from a smaller batch."""
    stacks = [_stack("cylinder", 10.0, 0.01, 16), _stack("sphere", 8.0, 5e-4, 8)]
    P, N, mask = (np.concatenate(parts) for parts in zip(*stacks, strict=True))
    seen = {}
    real = centre_jet._split_fits
    mocker.patch.object(centre_jet, "_split_fits", lambda *a: seen.setdefault("a", a) and real(*a))
    centre_jet.fit(P, N, mask)
    p, nrm, mask, sig, _, fits = seen["a"]
    geo = jet_rows.geometry(jet_rows.positions(p, mask), fits.coef, fits.model)
    first = jet_rows.make(p, nrm, mask, sig, geo, jet_rows.ORDER, part)
    own = jet_rows.geometry(first, jet_models.quadric(first).sol.coef)
    rows = jet_rows.make(p, nrm, mask, sig, own, jet_rows.ORDER, part)
    quad = jet_models.quadric(rows).sol
    want_coef, want_s2, _ = _split_round_of_all(rows, mask, quad, fits)
    runs = mocker.spy(jet_models, "round_model")
    sol, s2 = centre_jet._split_round(rows, mask, quad, fits)
    assert 0 < len(runs.call_args.args[0].b) < len(P)  # some patches skipped, some not
    assert np.any(fits.model == 1) and np.any(s2 > 1.0)
    np.testing.assert_array_equal(sol.coef, want_coef)
    np.testing.assert_array_equal(s2, want_s2)


def test_the_3_jets_truncation_view_is_fitted_only_where_the_3_jet_keeps_a_share(mocker):
    """Where the 2-jet shrinkage leaves the 3-jet no share its bias is discarded, so the
    4-jets are fitted on the other patches alone; there the bias is the whole stack's."""
    stacks = [_stack("cylinder", 10.0, 0.01, 24), _stack("sphere", 8.0, 5e-4, 8)]
    P, N, mask = (np.concatenate(parts) for parts in zip(*stacks, strict=True))
    real, seen = centre_jet._own_truncation, {}

    def both_ways(fits, need, rows, mask, start, sig, dof):  # before the blend changes fits
        up = centre_jet._next_order(rows, mask, fits.model, start)
        seen["everywhere"] = centre_jet._truncation(fits, *up, rows, sig, dof)
        seen["need"], seen["before"] = need, fits.bias.copy()
        views = mocker.spy(centre_jet, "_next_order")
        seen["got"] = real(fits, need, rows, mask, start, sig, dof)
        seen["fitted"] = len(views.call_args.args[0].b)
        return seen["got"]

    mocker.patch.object(centre_jet, "_own_truncation", both_ways)
    centre_jet.fit(P, N, mask)
    need, got = seen["need"], seen["got"]
    assert 0 < need.sum() < len(P) and seen["fitted"] == need.sum()
    np.testing.assert_array_equal(got[~need], seen["before"][~need])
    np.testing.assert_allclose(got[need], seen["everywhere"][need], rtol=1e-12, atol=1e-15)
    assert not np.array_equal(got[need], seen["before"][need])  # the view widens some


def test_each_contacts_unit_covariance_is_computed_once_and_is_t_m_t_transposed(mocker):
    """``Rows.unit`` (T P T^T, T N T^T) entry by entry equals the 3 x 3 products, and the
    rows of another order and a sub-stack reuse it instead of computing it again."""
    P, N, mask = _stack("cylinder", 10.0, 0.01, 6)
    rows = jet_rows.make(P, N, mask, np.full((6, 2), 0.01))
    made = mocker.spy(jet_rows, "_sandwich")
    KP, KN = rows.unit()
    for K, M in ((KP, rows.P), (KN, rows.N)):
        want = rows.T @ M @ np.swapaxes(rows.T, -1, -2)
        np.testing.assert_allclose(K, want, rtol=1e-13, atol=1e-13 * np.abs(want).max())
    low, some = jet_rows.with_order(rows, 2), rows.take([4, 1])
    assert low.unit()[0] is KP and np.array_equal(some.unit()[1], KN[[4, 1]])
    assert made.call_count == 2


def test_replacing_some_problems_of_a_solution_keeps_the_rest_and_the_original():
    """``batch_lstsq.replace``, how a sub-stack's fit goes back into the stack's."""
    from tactile.ep2 import batch_lstsq

    rng = np.random.default_rng(3)
    A, b, w = rng.normal(size=(5, 12, 4)), rng.normal(size=(5, 12)), np.ones((5, 12))
    whole = batch_lstsq.solve(A, b, w)
    other = batch_lstsq.solve(A[[3, 0]] * 2.0, b[[3, 0]], w[[3, 0]])
    before = whole.coef.copy()
    got = batch_lstsq.replace(whole, [3, 0], other)
    for key in batch_lstsq.FIELDS:
        np.testing.assert_array_equal(getattr(got, key)[[3, 0]], getattr(other, key))
        np.testing.assert_array_equal(getattr(got, key)[[1, 2, 4]], getattr(whole, key)[[1, 2, 4]])
    np.testing.assert_array_equal(whole.coef, before)
