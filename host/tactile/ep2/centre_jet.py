"""Default EP2 estimator: curvature AT THE PATCH CENTRE from a local jet, the model chosen by data.

For a stack of patches (padded arrays and a row mask), all at once:

1. **Frame** (§5.1.2): mean normal as z, centroid as origin (``jet_frames``);
   lengths divided by the patch size L; origin moved to the middle of the
   contacts' box (the patch centre).
2. **Noise** (§4.9 weights made statistical): positions get 1/(sigma_p sqrt(1+g^2)),
   slopes 1/(sigma_n (1+g^2)).  A sigma not stated is estimated per row type
   from an order-5 jet (REML: residual sum over rows minus leverage; ``jet_noise``,
   the rows and their whitening in ``jet_rows``).
3. **Osculating frame**: twice, the frame is turned so its z axis is the fitted
   normal at the centre and its origin the fitted surface point there.
4. **Two models of equal size** (3-jets, ``jet_basis``): ``quadric`` (the
   Taylor polynomial) and ``round`` (its quadratic part replaced by the closed
   form that is exact for spheres and cylinders of any radius and axis,
   solved by Gauss-Newton; ``jet_models``).  ``round`` is chosen when its chi^2 is lower by
   more than ``ROUND_MARGIN``; a quadric height field keeps ``quadric``.  The same pair
   as 2-jets, and t shrunk toward theirs where the 3-jet's extra terms buy only variance
   (``_lower_order``: three uneven finger lines under noisy normals).
5. **Curvature at the centre**: shape-operator entries t = (a, b, c)
   (``surface_geometry.shape_entries``) with Cov(t) propagated through the
   linear map from the weighted data (``jet_covariance``).  The noise in Cov is never below
   ``jet_covariance.FLOOR`` (relative), so noise-free or duplicated data cannot claim
   infinite precision; the other model's difference, weighted by its
   relative likelihood, or the chosen model's truncation as that model one order up sees
   it (``_truncation``), is kept as a bias vector for the intervals.

Nothing here raises for one bad patch: ``reason`` holds why a patch is refused.
"""

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from tactile.ep2 import (
    batch_lstsq,
    jet_basis,
    jet_covariance,
    jet_frames,
    jet_models,
    jet_noise,
    jet_rows,
)

ORDER = jet_rows.ORDER  # jet order of both models


ROUND_MARGIN = 4.0  # chi^2 by which 'round' must beat 'quadric' to be chosen
AMBIGUOUS = 8.0  # chi^2 gaps within this leave the choice open: intervals cover both models
MODELS = ("quadric", "round")
# Gauss-Newton tolerances (``jet_models.GN_TOL`` for the final fit): the passes that only
# place the frame and weight the rows, and the one-row-type fits that only feed a chi^2 test,
# stop at 1e-8 (the estimates move by ~1e-9 relative; bench/ep2_speed.py: ~1/10 of the time)
PASS_TOL = 1e-8
SHRINK = 3.0  # t_3 shrunk to t_2 by max(0, 1 - SHRINK (v_3 - v_2) / |t_3 - t_2|^2)
ROUNDOFF = 1e-9  # relative: a 2-jet / 3-jet difference below it is round-off (``_shrink_weight``)
SPLIT_TOL = 1e-8


@dataclass
class JetFits:
    """Per patch (leading axis B): see the module docstring.  Lengths / L except ``noise``."""

    t: np.ndarray  # (B, 3) shape-operator entries at the centre
    cov: np.ndarray  # (B, 3, 3)
    cov_noise: np.ndarray  # (B, 3, 3) the same without the floor: the estimate's own scatter
    bias: np.ndarray  # (B, 3) model-choice bias vector (0 when the choice is clear)
    dof: np.ndarray  # (B,) degrees of freedom of the noise estimate behind cov (inf: known)
    model: np.ndarray  # (B,) index into MODELS
    chi2: np.ndarray  # (B, len(MODELS)) weighted RSS of each model (inf: round invalid)
    score: np.ndarray  # (B, len(MODELS)) chi2 + 2 rank (+ ROUND_MARGIN for round): lowest wins
    coef: np.ndarray  # (B, p) chosen model's jet coefficients (round: excess added separately)
    scale: np.ndarray  # (B,) L
    origin: np.ndarray  # (B, 3) world coordinates of the final frame's origin
    axes: np.ndarray  # (B, 3, 3) rows: final frame's x, y, z in world coordinates
    noise: np.ndarray  # (B, 2) sigma_pos (input unit), sigma_normal (rad) used for the weights
    stated: tuple  # (pos, normal) stated by the user
    xy: np.ndarray  # (B, n, 2) contacts in the final frame (/ L)
    mask: np.ndarray  # (B, n)
    reason: list  # per patch: None, or why it is refused
    split: tuple  # positions alone, normals alone (``_split_fits``)
    order: np.ndarray = None  # (B,) jet order of the chosen model
    weight: np.ndarray = None  # (B,) the 3-jet's share w of t, 1 - w its 2-jet's (``_lower_order``)
    xyz_mean: np.ndarray = None  # (B, n, 3) contacts in the mean-normal frame (/ L)
    mean_axes: np.ndarray = None  # (B, 3, 3) that frame's axes in world coordinates


def fit(points, normals, mask, noise_pos=None, noise_normal=None, max_angle_deg=70.0,
        intervals=True):  # fmt: skip
    """Fit every patch of the stack: points, normals (B, n, 3) (unit normals), mask (B, n).
    Without ``intervals`` the truncation views (``_truncation``: a 4-jet solve and a round
    4-jet's Gauss-Newton), which only widen intervals, are not computed: ``bias`` is the
    model-choice one alone, and every other field is the same."""
    mask = np.asarray(mask, bool)
    reason = [None] * len(mask)
    O, M = jet_frames.mean_frame(points, normals, mask, reason)
    mean_axes = M
    p = np.einsum("bij,bnj->bni", M, points - O[:, None, :])
    nrm = np.einsum("bij,bnj->bni", M, normals)
    jet_frames.check_angles(nrm, mask, max_angle_deg, reason)
    L = jet_frames.size(p, mask, reason)
    centre = 0.5 * (jet_frames.masked_min(p, mask) + jet_frames.masked_max(p, mask))
    centre[:, 2] = 0.0
    O = O + np.einsum("bi,bij->bj", centre, M)
    p = (p - centre[:, None, :]) / L[:, None, None]
    xyz_mean = p.copy()
    sig, dof = jet_noise.estimate(p, nrm, mask, noise_pos, noise_normal, L)
    first = jet_models.quadric(jet_models.refit_rows(p, nrm, mask, sig))
    O, M, p, nrm = jet_frames.reframe(O, M, L, p, nrm, first.sol.coef)
    quad, rnd = jet_models.both(jet_models.refit_rows(p, nrm, mask, sig), mask, tol=PASS_TOL)
    better = np.where(rnd.ok & (rnd.sol.rss < quad.sol.rss), 1, 0)
    coef = np.where(better[:, None] == 1, rnd.sol.coef, quad.sol.coef)
    O, M, p, nrm = jet_frames.reframe(O, M, L, p, nrm, coef)
    rows = jet_models.refit_rows(p, nrm, mask, sig)
    quad, rnd = jet_models.both(rows, mask, rnd.sol.coef, PASS_TOL)
    better = np.where(rnd.ok & (rnd.sol.rss < quad.sol.rss), 1, 0)
    coef = np.where(better[:, None] == 1, rnd.sol.coef, quad.sol.coef)
    geo = jet_rows.geometry(jet_rows.positions(p, mask), coef, better)
    rows = jet_rows.make(p, nrm, mask, sig, geo)
    quad, rnd = jet_models.both(rows, mask, rnd.sol.coef)
    frame, stated = (L, O, M), (noise_pos, noise_normal)
    out = _finish([quad, rnd], rows, mask, sig, dof, frame, stated, reason)
    low_rows = jet_rows.with_order(rows, ORDER - 1)
    start = rnd.sol.coef[:, : jet_basis.n_coef(ORDER - 1)]
    low = _finish(list(jet_models.both(low_rows, mask, start)), low_rows, mask, sig, dof, frame,
                  stated, reason)  # fmt: skip
    keep = _shrink_weight(out, low, 3.0 * mask.sum(axis=1))
    if intervals:
        low.bias = _truncation(low, *_judges(low.model, quad, rnd, rnd.ok), low_rows, sig, dof)
        out.bias = _own_truncation(out, keep > 0, rows, mask, rnd.sol.coef, sig, dof)
    out = _lower_order(out, low, keep)
    out.split = _split_fits(p, nrm, mask, sig, dof, out)
    out.xyz_mean, out.mean_axes = xyz_mean, mean_axes
    return out


def _finish(models, rows, mask, sig, dof, frame, stated, reason):
    """Choose between ``models`` (``MODELS``) by chi^2 + 2 x rank (round must beat the
    quadric by ``ROUND_MARGIN`` more); the runner-up's estimate, weighted by its relative
    likelihood (1 within ``AMBIGUOUS``), is the bias vector for the intervals.

    Tried on the first holdout and declined: adding quadric 2- and 4-jets to the choice
    (by AIC: better on tilted quadric height fields, whose 3-jet keeps a truncation bias,
    but a 4-jet runner-up's noisy estimate widened small patches into refusals), and a
    focused criterion (the tensor's MSE estimated against the 4-jet: its bias estimate is
    too noisy; worse on cylinders)."""
    L, O, M = frame
    chi2 = np.stack([np.where(m.ok, m.sol.rss, np.inf) for m in models], axis=1)
    rank = np.stack([m.sol.rank for m in models], axis=1).astype(float)
    score = chi2 + 2.0 * rank
    score[:, 1] += ROUND_MARGIN
    score = np.nan_to_num(score, nan=np.inf)
    order = np.argsort(score, axis=1, kind="stable")
    model, runner = order[:, 0], order[:, 1]
    out = []
    for m in models:
        t, G = jet_covariance.tensor(m.sol.coef, m.sol.pinv)
        out.append((t, *jet_covariance.propagate(G, rows, m.sol.rss, m.sol.rank, sig, dof)))
    t_all, cov_all, nu_all, raw_all = (np.stack([o[k] for o in out], axis=1) for k in range(4))

    def take(a, idx):
        return a[np.arange(len(idx)), idx]

    t, cov, nu, cov_noise = (take(a, model) for a in (t_all, cov_all, nu_all, raw_all))
    other = take(t_all, runner)
    gap = take(score, runner) - take(score, model)  # >= 0
    p_other = np.exp(-0.5 * np.minimum(np.nan_to_num(gap, nan=np.inf), 1400.0))
    p_other = np.where(gap <= AMBIGUOUS, 1.0, p_other)
    bias = np.sqrt(p_other)[:, None] * np.where(np.isfinite(other), other - t, 0.0)
    width = max(m.sol.coef.shape[1] for m in models)
    padded = np.stack([_pad(m.sol.coef, width) for m in models], axis=1)
    coef = take(padded, model)
    return JetFits(
        t=t,
        cov=cov,
        cov_noise=cov_noise,
        bias=bias,
        dof=nu,
        model=model,
        chi2=chi2,
        score=score,
        coef=coef,
        scale=L,
        origin=O,
        axes=M,
        noise=np.stack([sig[:, 0] * L, sig[:, 1]], axis=1),
        stated=tuple(v is not None for v in stated),
        xy=np.stack([rows.x, rows.y], axis=-1),
        mask=mask,
        reason=reason,
        split=(),
        order=np.full(len(chi2), jet_basis.order_of(width)),
    )


def _lower_order(high, low, keep):
    """The 3-jet's t shrunk toward the 2-jet's, t_2 + w (t_3 - t_2), w = ``keep``
    (``_shrink_weight``).  The estimate's own scatter
    (``cov_noise``, for the debiasing) is (1 - w^2) Cov_2 + w^2 Cov_3 (``jet_shrink``); the
    intervals and tests keep Cov_3 (>= that, nested): a 2-jet whose bias the data cannot
    see may still have one (a cluster of contacts).  The model fields are the 2-jet pair's
    where w < 1/2.  Why: three finger
    lines leave the 3-jet's positions blind to (u - u1)(u - u2)(u - u3) (u across the lines),
    which confounds the curvature across them with the cubic along u; only the slopes part
    them, so with normals much noisier than the positions the 3-jet's curvature is the
    normals' (holdout3: sd 6-10 x the 2-jet's)."""
    w = keep[:, None]
    high.weight = keep
    for key in ("t", "bias", "coef"):
        a, b = getattr(high, key), getattr(low, key)
        b = _pad(b, a.shape[1]) if key == "coef" else b
        setattr(high, key, b + w * (a - b))
    w2 = (keep * keep)[:, None, None]  # the estimate's own scatter, for the debiasing
    high.cov_noise = (1.0 - w2) * low.cov_noise + w2 * high.cov_noise
    use = keep < 0.5
    high.dof = np.minimum(high.dof, low.dof)
    for key in ("model", "chi2", "score", "order"):
        a, b = getattr(high, key), getattr(low, key)
        shape = use.reshape(use.shape + (1,) * (np.ndim(a) - 1))
        setattr(high, key, np.where(shape, b, a))
    return high


def _shrink_weight(high, low, used):
    """w = max(0, 1 - SHRINK v / |t_3 - t_2|^2), v = v_3 - v_2 (v = tr Cov(t) of the noise
    alone, without the misfit scaling: nested fits, so |t_3 - t_2|^2 ~ v chi^2_3 / 3 where
    the 2-jet is unbiased), the positive-part rule ``_truncation`` uses; 0 where the two
    jets agree to round-off.  ``used`` (B,): the rows of each patch."""
    v = []
    for fits in (high, low):
        rss = np.take_along_axis(fits.chi2, fits.model[:, None], axis=1)[:, 0]
        rank = jet_basis.n_coef(fits.order)
        s2 = np.maximum(rss / np.maximum(used - rank, 1), 1.0)
        v.append(np.trace(fits.cov_noise, axis1=1, axis2=2) / s2)
    d = np.sum((low.t - high.t) ** 2, axis=1)
    spare = np.maximum(v[0] - v[1], 0.0)
    # round-off is no excess: jets that agree to it report the 2-jet, whatever the scale
    d = np.where(d > (ROUNDOFF * np.maximum(1.0, np.abs(high.t).max(axis=1))) ** 2, d, 0.0)
    spare = np.where(spare > ROUNDOFF * v[1], spare, 0.0)
    keep = np.maximum(1.0 - SHRINK * spare / np.where(d > 0, d, np.inf), 0.0)
    keep = np.where(d > 0, keep, 0.0)
    keep = np.where(np.isfinite(d), keep, 1.0)
    return keep


def _truncation(fits, up, full, rows, sig, dof):
    """The bias vector for the intervals: the model-choice one, or the chosen model's
    truncation as the same model one order up sees it (``up``, per patch: ``_judges``),
    whichever is larger.  The difference d = t_up - t is shrunk by its own noise,
    max(0, 1 - 3 v / |d|^2) with v = tr Cov(t_up) - tr Cov(t) (under no bias |d|^2 ~
    v chi^2_3 / 3: kept in ~3 % of noise-only draws), so it only widens where the next order
    sees a curvature this one misses (strongly curved, tilted height fields).  Nothing where
    the layout does not determine the next order (``full``: the quadric's rank), nor where
    its round fit has not converged (chi^2 above the nested smaller fit's).  The round model
    is judged by the round model one order up, not by the quadric's: the closed form holds
    every even order of a sphere or cylinder, which a quadric jet truncates, so there d is
    noise; but a round 3-jet also wins the chi^2 choice on strongly curved general quadrics
    while misfitting them (holdout4: chi^2 / dof 2-150, S off by 5-8 sd)."""
    t4, G = jet_covariance.tensor(up.sol.coef, up.sol.pinv)
    raw4 = jet_covariance.propagate(G, rows, up.sol.rss, up.sol.rank, sig, dof)[2]
    d = np.where(np.isfinite(t4), t4 - fits.t, 0.0)
    v = np.maximum(np.trace(raw4, axis1=1, axis2=2) - np.trace(fits.cov_noise, axis1=1, axis2=2), 0)
    size = np.sum(d * d, axis=1)
    keep = np.maximum(1.0 - 3.0 * v / np.where(size > 0, size, np.inf), 0.0)
    round_ = fits.model == 1
    own = np.take_along_axis(fits.chi2, round_[:, None].astype(int), axis=1)[:, 0]
    # a nested larger fit cannot fit worse: if it does, its Gauss-Newton has not converged
    done = up.ok & (up.sol.rss <= own * (1.0 + 1e-6) + 1e-9)
    keep = np.where(full & (~round_ | done), np.nan_to_num(keep), 0.0)
    trunc = keep[:, None] * d
    larger = np.sum(trunc * trunc, axis=1) > np.sum(fits.bias * fits.bias, axis=1)
    return np.where(larger[:, None], trunc, fits.bias)


def _judges(model, quad, rnd, ok):
    """(the fit that judges each patch's truncation, ``full``): ``rnd``'s where ``model``
    chose the round model (usable where ``ok``), ``quad``'s elsewhere; ``full`` where the
    quadric one order up has full rank."""
    idx = np.flatnonzero(model == 1)
    sol = batch_lstsq.replace(quad.sol, idx, batch_lstsq.take(rnd.sol, idx))
    full = quad.sol.rank == quad.sol.coef.shape[1]
    return jet_models.Model(sol, None, ok | (model != 1)), full


def _own_truncation(fits, need, rows, mask, start, sig, dof):
    """``fits.bias`` with ``_truncation`` where ``need``: the 3-jet's own truncation view
    only where the 3-jet has a share (w > 0); elsewhere the blend (``_lower_order``)
    discards its bias, so neither 4-jet is fitted there (the round one is a Gauss-Newton
    from ``start``).  The patches are independent: a sub-stack gives each what the whole
    stack would."""
    idx = np.flatnonzero(need)
    if not idx.size:
        return fits.bias
    sub = SimpleNamespace(
        **{k: getattr(fits, k)[idx] for k in ("t", "cov_noise", "model", "chi2", "bias")}
    )
    some = rows.take(idx)
    up = _next_order(some, mask[idx], sub.model, start[idx])
    bias = fits.bias.copy()
    bias[idx] = _truncation(sub, *up, some, sig[idx], dof[idx])
    return bias


def _next_order(rows, mask, model, start):
    """``_judges`` one order above ``rows``: the quadric 4-jet, and the round 4-jet (a
    Gauss-Newton from ``start``) where ``model`` chose the round model."""
    up = jet_rows.with_order(rows, ORDER + 1)
    quad = jet_models.quadric(up)
    full = quad.sol.rank == quad.sol.coef.shape[1]
    idx, ok = np.flatnonzero(model == 1), model != 1
    if not idx.size:
        return jet_models.Model(quad.sol, None, ok), full
    fit = jet_models.round_model(
        up.take(idx), mask[idx], _pad(start[idx], up.A.shape[-1]), PASS_TOL
    )
    ok[idx] = fit.ok
    return jet_models.Model(batch_lstsq.replace(quad.sol, idx, fit.sol), None, ok), full


def _split_round(rows, mask, quad, fits):
    """(the solution of the joint fit's model on one row type's ``rows``, that row type's
    misfit s^2 under its own better family): the quadric ``quad``, or where the joint fit
    chose the round model a Gauss-Newton from its solution.  The misfit, max(chi^2 / dof,
    1) of the lower chi^2 (model error, not disagreement), needs the round fit only where
    the quadric's chi^2 / dof is above 1, so the round model runs on those patches and the
    round ones alone (the rest get exactly what a fit of all would give them)."""
    dof = np.maximum(rows.w.sum(axis=1) - quad.rank, 1)
    need = np.flatnonzero((fits.model == 1) | (quad.rss > dof))
    own_s2 = np.maximum(quad.rss / dof, 1.0)
    if not need.size:
        return quad, own_s2
    sub = rows.take(need)
    start = np.where((fits.model[need] == 1)[:, None], fits.coef[need, : quad.coef.shape[1]],
                     quad.coef[need])  # fmt: skip
    rnd = jet_models.round_model(sub, mask[need], start, SPLIT_TOL)
    best = np.minimum(quad.rss[need], np.where(rnd.ok, rnd.sol.rss, np.inf))
    own_s2[need] = np.maximum(best / dof[need], 1.0)
    pick = (fits.model[need] == 1) & rnd.ok  # the joint fit's model, refitted
    if not pick.any():
        return quad, own_s2
    return batch_lstsq.replace(quad, need[pick], batch_lstsq.take(rnd.sol, pick)), own_s2


def _pad(coef, width):
    """Jet coefficients padded with zeros to ``width`` (graded order: the same polynomial)."""
    return np.pad(coef, ((0, 0), (0, width - coef.shape[1])))


def _split_fits(p, nrm, mask, sig, dof, fits):
    """Each row type fitted alone with the joint fit's model (round: Gauss-Newton from the
    joint solution; nothing held from it, which may be nonsense when they disagree): two
    independent estimates of the five derivatives (z_x, z_y, z_xx, z_xy, z_yy) at the
    centre, which agree within their covariances when positions and normals describe one
    surface.  Returns ((d, cov, seen) positions, (d, cov, seen) normals), ``seen`` =
    (blind (B, p, 5), scale (B, 5)) of ``batch_lstsq`` for the five derivatives: what that
    row type does not determine (positions on two lines do not give z_xx; nothing on one
    line gives the curvature across it)."""
    geo = jet_rows.geometry(jet_rows.positions(p, mask), fits.coef, fits.model)
    out = []
    for part in ("pos", "slopes"):
        first = jet_rows.make(p, nrm, mask, sig, geo, jet_rows.ORDER, part)
        own = jet_rows.geometry(
            first, jet_models.quadric(first).sol.coef
        )  # the joint fit may be nonsense
        rows = jet_rows.make(p, nrm, mask, sig, own, jet_rows.ORDER, part)
        model = jet_models.quadric(rows)
        sol, own_s2 = _split_round(rows, mask, model.sol, fits)
        ch = list(jet_basis.CHANNELS)
        # the noise, times the misfit of the row type's own better family only: a joint
        # family that misfits one row type (mirrored normals, say) must not widen its way
        # out of the comparison, but a surface no 3-jet follows is not a disagreement
        cov, _, _ = jet_covariance.propagate(
            sol.pinv[:, ch, :], rows, np.zeros_like(sol.rss), sol.rank, sig, dof
        )
        cov = cov * own_s2[:, None, None]
        out.append((sol.coef[:, ch], cov, (sol.blind[:, :, ch], sol.scale[:, ch])))
    return tuple(out)
