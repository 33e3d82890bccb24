"""The default EP2 fit: jets of positions and normals about the patch centre, for a stack.

In one's head (thesis §4.5-4.6 made local; §5.1.2's frame):

1. **Frame.**  Origin at the contacts' centroid, z along their mean normal (seeded at the
   medoid normal, so one flipped normal cannot turn it), lengths in units of L, the larger
   side of their box; the curvature is wanted at the box's middle, the patch centre.
2. **Rows.**  Each contact gives its height z and, from its normal, two slopes
   (-nx/nz, -ny/nz).  A jet of order m is the Taylor polynomial about the centre,
   sum c_ij x^i y^j / (i! j!), so its coefficients are the derivatives there.  Rows are
   weighted by their noise: positions 1/(sigma_p sqrt(1 + g^2)), slopes
   1/(sigma_n (1 + g^2)), g the contact's slope.  A sigma not stated is estimated from
   that row type's residuals (RSS over rows minus leverage) in the highest jet with at
   least ``NOISE_REDUNDANCY`` rows per term.
3. **Every order at once.**  One QR of the jet of the highest order the contacts
   determine (up to ``TOP_ORDER``, columns by degree) gives every lower jet too: the
   leading columns of a QR are the QR of the leading columns.
4. **Outliers.**  A contact whose normal is over ``MAX_ANGLE`` from the patch's, or whose
   three residuals jointly fail a chi^2 test at the patch's own scale, is left out and
   named; at most ``MAX_OUTLIERS``.  Then that patch is fitted again without it.
5. **The answer** is the 2-jet, moved toward the jet one below the top by the evidence
   that its curvature differs from the 2-jet's (James-Stein, ``SHRINK`` times the
   statistic's degrees of freedom): noise keeps the 2-jet, a surface the 2-jet cannot
   follow moves it.  Its covariance counts the noise and the bias left: the answer's
   difference to the top jet where it exceeds ``BIAS_EVIDENCE`` times that difference's
   noise, and the order above the top, sized as a sphere or cylinder of the measured
   curvature would size it (a circle's z6 = 5 z4^2 / z2).

``fit`` returns a ``jet_answers.JetStack`` (items 5-6 are ``jet_answers``'), each patch
whose positions and normals describe different surfaces refused in it (``disagreements``,
docs/ep2.md step 8); ``jet_answers.outcomes`` turns it into answers and refusals.  Each pass
of the fit is a ``JetFit``.
"""

import math
from dataclasses import dataclass

import numpy as np

from tactile.ep2 import jet_answers
from tactile.ep2.geometry import design, mv, pick, size, stacked_design, unit, vm

TOP_ORDER = 4
TOP_REDUNDANCY = 1.2  # an order is fitted where the rows are this many times its terms
NOISE_REDUNDANCY = 2.0  # the noise and outlier tests use the order with this many
MAX_ANGLE = 80.0  # deg: a normal further from the patch's is not of this patch
FLOOR = 1e-8  # noise floor: of L for positions, rad for normals (exact data stay exact)
START_NOISE = 0.01  # the first pass's sigmas when none is stated (of L, rad)
MAX_OUTLIERS = 2  # contacts left out by the deletion test; one more refuses the patch
GROSS_POSITION = 0.05  # of L: a point off by less is not called an outlier, whatever the test
GROSS_ANGLE = 10.0  # deg: nor a normal turned by less
ISOLATED = 4.0  # an outlier's statistic is this many times that of the contacts after the worst
CHEAP_COND = 1e4  # a stiffer jet takes LAPACK's formed Q (see _qr)


@dataclass
class JetFit:
    """One pass of the fit over a stack (B patches, n rows each, 3n weighted rows): the QR of
    the top jet and what each order and the frame need; lengths / L."""

    Q: np.ndarray  # (B, 3n, p_top) the weighted, column-scaled jet's Q
    Rinv: np.ndarray  # (B, p_top, p_top) its R's inverse (a singular pivot taken as 1)
    cn: np.ndarray  # (B, p_top) the column scales
    qb: np.ndarray  # (B, p_top) Q^T (weighted right-hand side)
    top: np.ndarray  # (B,) the highest order the rows determine
    quiet: np.ndarray  # (B,) the order the noise and outlier tests use
    ok2: np.ndarray  # (B,) whether the 2-jet is determined
    Aw: np.ndarray  # (B, 3n, p) the weighted jet, with the order above the top
    w: np.ndarray  # (B, 3n) the rows' weights (0: left out)
    resid: dict  # order -> (B, 3n) weighted residuals (the orders in ``quiet`` and ``top``)
    hat: dict  # order -> (B, 3n) leverages (the orders in ``quiet``)
    origin: np.ndarray = None  # (B, 3) the frame (world), its axes' rows (B, 3, 3), L (B,)
    axes: np.ndarray = None
    L: np.ndarray = None
    centre: np.ndarray = None  # (B, 2) the box middle in the frame
    xy: np.ndarray = None  # (B, n, 2) contacts about the centre
    g2: np.ndarray = None  # (B, n) squared slopes
    sig: np.ndarray = None  # (B, 2) sigma_p (/ L), sigma_n (rad) the weights used
    stated: np.ndarray = None  # (B, 2) which of them were stated
    spread: np.ndarray = None  # (B,) L, 0 for one point
    heights: np.ndarray = None  # (B, n)
    slopes: np.ndarray = None  # (B, n, 2)

    @property
    def n(self):
        return self.xy.shape[1]

    def take(self, idx):
        """The fit of the patches ``idx`` only."""
        return JetFit(**{k: _rows(v, idx) for k, v in vars(self).items()})

    def put(self, idx, other):
        """Write ``other``, the fit of the patches ``idx``, into this one."""
        for k, v in vars(other).items():
            mine = getattr(self, k)
            if isinstance(v, dict):
                for o, a in v.items():
                    if o not in mine:  # (an order only the refitted patches use)
                        mine[o] = np.zeros((len(self.top), *a.shape[1:]))
                    mine[o][idx] = a
            elif v is not None:
                mine[idx] = v


def _rows(v, idx):
    if isinstance(v, dict):
        return {o: a[idx] for o, a in v.items()}
    return None if v is None else v[idx]


def fit(P, N, mask, noise_pos=None, noise_normal=None, max_angle=MAX_ANGLE):
    """Fit every patch of the stack: P, N (B, n, 3) world points and unit normals (rows
    beyond a patch's contacts masked out by ``mask`` (B, n)).  ``noise_pos`` (input unit)
    and ``noise_normal`` (rad): None (estimated), a number, or one per patch (NaN: estimated);
    ``max_angle`` (deg): a normal further from the patch's is left out.
    After an outlier is left out only the patches that lost one are fitted again."""
    P, N, mask = np.asarray(P, float), np.asarray(N, float), np.asarray(mask, bool)
    noise = np.stack([_per_patch(noise_pos, len(P)), _per_patch(noise_normal, len(P))], -1)
    keep, warnings = screen_normals(N, mask, max_angle)
    limit = math.tan(math.radians(min(max_angle, 89.9)))
    n_kept = keep.sum(-1).max() if len(P) else 0
    top_cap = max(
        [2, *(o for o in range(3, TOP_ORDER + 1) if TOP_REDUNDANCY * size(o) <= 3 * n_kept)]
    )
    reason = [None] * len(P)
    live = np.arange(len(P))
    f = _fit_once(P, N, keep, noise, top_cap, limit)
    for _ in range(MAX_OUTLIERS + 1):
        whole = len(live) == len(P)  # (the first pass: every patch, no copy of the fit)
        worst, why = worst_contact(f if whole else f.take(live), keep if whole else keep[live])
        again = []
        for k in np.flatnonzero(worst >= 0):
            b = int(live[k])
            if len(warnings[b]) >= MAX_OUTLIERS:
                reason[b] = reason[b] or (
                    f"more than {MAX_OUTLIERS} contacts disagree with the surface the others "
                    f"describe ({why[k]}): too few consistent contacts"
                )
                continue
            keep[b, worst[k]] = False
            warnings[b].append(f"contact {worst[k]} left out: {why[k]}")
            again.append(b)
        if not again:
            break
        live = np.array(again)
        f.put(live, _fit_once(P[live], N[live], keep[live], noise[live], top_cap, limit))
    stack = jet_answers.answer(f, keep, reason, warnings, np.isfinite(noise))
    refuse_disagreeing(stack)
    return stack


def _per_patch(v, B):
    """A noise argument as (B,) floats, NaN where not stated."""
    if v is None:
        return np.full(B, np.nan)
    return np.broadcast_to(np.asarray(v, float), (B,)).copy()


# --- 1. screening and the frame -------------------------------------------------------------
def _frame(P, N, keep):
    """(origin (B, 3), axes (B, 3, 3), L (B,), centre (B, 2), spread (B,): L, 0 for one point)
    as ``geometry.frame_from_contacts`` builds it, from the contacts kept."""
    w = keep.astype(float)
    z = unit(vm(w, N))
    ref = np.where((np.abs(z[:, :1]) < 0.9), [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    x = unit(ref - z * np.sum(ref * z, -1, keepdims=True))
    axes = np.stack([x, np.cross(z, x), z], axis=1)
    origin = vm(w, P) / np.maximum(w.sum(-1), 1.0)[:, None]
    q = (P - origin[:, None]) @ np.swapaxes(axes, -1, -2)[..., :2]
    lo = np.where(keep[..., None], q, np.inf).min(1)
    hi = np.where(keep[..., None], q, -np.inf).max(1)
    L = np.max(hi - lo, -1)
    return origin, axes, np.where(L > 0, L, 1.0), 0.5 * (lo + hi), L


# --- 2-3. rows, weights, noise and every order from one QR -----------------------------------
def _fit_once(P, N, keep, noise, top_cap, limit):
    """Frame, rows, noise and the jets of every order up to the top, for the contacts kept."""
    origin, axes, L, centre, spread = _frame(P, N, keep)
    centre = centre / L[:, None]
    q = (P - origin[:, None]) @ np.swapaxes(axes, -1, -2) / L[:, None, None]
    nn = N @ np.swapaxes(axes, -1, -2)
    nz = np.maximum(nn[..., 2], 1e-6)
    sx = np.clip(-nn[..., 0] / nz, -limit, limit)
    sy = np.clip(-nn[..., 1] / nz, -limit, limit)
    x, y = q[..., 0] - centre[:, :1], q[..., 1] - centre[:, 1:]
    n_kept = keep.sum(-1)
    A = stacked_design(x, y, top_cap + 1)  # (the extra order: the top's truncation)
    b = np.concatenate([q[..., 2], sx, sy], -1)
    g2 = sx * sx + sy * sy
    kk = np.tile(keep, 3).astype(float)
    stated = np.isfinite(noise)
    sig = np.where(stated, noise / np.stack([L, np.ones_like(L)], -1), START_NOISE)
    for rnd in range(2):
        s = np.maximum(sig, FLOOR)
        wp = 1.0 / (s[:, :1] * np.sqrt(1.0 + g2))
        ws = 1.0 / (s[:, 1:] * (1.0 + g2))
        w = np.concatenate([wp, ws, ws], -1) * kk
        last = rnd == 1 or stated.all()
        f = _qr_fits(A, b, w, top_cap, n_kept, last)
        if last:
            break
        sig = _reml(f, s, stated, keep)
    f.origin, f.axes, f.L, f.centre, f.xy, f.g2 = origin, axes, L, centre, np.stack([x, y], -1), g2
    f.sig, f.stated, f.spread = np.maximum(sig, FLOOR), stated, spread
    f.heights, f.slopes = q[..., 2], np.stack([sx, sy], -1)
    return f


def _qr_fits(A, b, w, top_cap, n_kept, solve=True):
    """One QR of the weighted jet (columns by degree) and what it says of every order: the
    residuals and leverages of order o are those of Q's first size(o) columns.  Without
    ``solve`` (a pass that only sizes the noise) R is not inverted nor the order above the
    top weighted."""
    p_top = size(top_cap)
    short = p_top - A.shape[1]  # fewer rows than the top jet's terms: zero rows, so R is square
    if short > 0:
        A = np.concatenate([A, np.zeros((len(A), short, A.shape[2]))], 1)
        b, w = (np.concatenate([v, np.zeros((len(v), short))], 1) for v in (b, w))
    bw = b * w
    Aw = A * w[..., None] if solve else None  # (with the order above the top: its bias)
    X = Aw[..., :p_top] if solve else A[..., :p_top] * w[..., None]
    cn = np.sqrt(np.einsum("bij,bij->bj", X, X))
    cn = np.where(cn > 0, cn, 1.0)
    R, d, Rinv, Q = _qr(X, cn)
    top = np.full(len(A), 2)
    quiet = np.full(len(A), 2)
    for o in range(3, top_cap + 1):
        det = d[:, : size(o)].min(-1) > 1e-9 * d[:, 0]
        fits = (TOP_REDUNDANCY * size(o) <= 3 * n_kept) & det
        top = np.where(fits & (top == o - 1), o, top)
        fits = (NOISE_REDUNDANCY * size(o) <= 3 * n_kept) & det
        quiet = np.where(fits & (quiet == o - 1), o, quiet)
    qb = vm(bw, Q)
    resid, hat = {}, {}  # (the orders the noise, the outlier test and the answer read)
    for o in np.unique(np.concatenate([quiet, top] if solve else [quiet])).tolist():
        Qo = Q[..., : size(o)]
        resid[o] = bw - mv(Qo, qb[:, : size(o)])
        if o in quiet:
            hat[o] = np.einsum("bij,bij->bi", Qo, Qo)
    ok2 = d[:, :6].min(-1) > 1e-9 * d[:, 0]
    return JetFit(Q, Rinv if solve else None, cn, qb, top, quiet, ok2, Aw, w, resid, hat)


def _qr(X, cn):
    """(R, |diag R|, R^-1, Q) of the column-scaled jet X / cn for a stack.  R is Householder's
    (which commutes with scaling the columns) and Q is X R^-1: LAPACK's formed Q costs 3-5 x
    at 15 columns.  X R^-1 is orthogonal to about cond * eps and the solutions through it to
    about cond^2 * eps (the semi-normal equations), so a patch whose jet is stiffer than
    ``CHEAP_COND`` (by ||R||_F ||R^-1||_F, an upper bound) takes LAPACK's Q and R."""
    R = np.linalg.qr(X, mode="r") / cn[:, None, :]
    d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    Rinv = _upper_inverse(R, d)
    Q = X @ (Rinv / cn[:, :, None])
    cond = np.sqrt(np.einsum("bij,bij->b", R, R) * np.einsum("bij,bij->b", Rinv, Rinv))
    stiff = np.flatnonzero(~(cond <= CHEAP_COND))
    if len(stiff):
        Q[stiff], R[stiff] = np.linalg.qr(X[stiff] / cn[stiff, None, :])
        d[stiff] = np.abs(np.diagonal(R[stiff], axis1=-2, axis2=-1))
        Rinv[stiff] = _upper_inverse(R[stiff], d[stiff])
    return R, d, Rinv, Q


def _upper_inverse(R, d):
    """Inverses of the stack's upper-triangular R, a singular diagonal taken as 1 (those
    orders are not used)."""
    p = R.shape[-1]
    tiny = d < 1e-9 * d[:, :1]
    R = R + np.eye(p) * tiny[:, None, :]
    return np.linalg.inv(R)


def _reml(f, s, stated, keep):
    """Each row type's sigma from its residuals in the top jet: RSS over (rows - leverage)."""
    n = keep.shape[1]
    out = s.copy()
    r = pick(f.resid, f.quiet)
    h = pick(f.hat, f.quiet)
    kk = np.tile(keep, 3)
    for t, cols in ((0, slice(0, n)), (1, slice(n, 3 * n))):
        rss = np.sum((r[:, cols] ** 2) * kk[:, cols], -1)
        dof = np.sum((1.0 - h[:, cols]) * kk[:, cols], -1)
        est = s[:, t] * np.sqrt(np.maximum(rss, 0.0) / np.maximum(dof, 0.5))
        out[:, t] = np.where(stated[:, t], s[:, t], est)
    return out


# --- 4. outliers: contacts that are no part of the surface the others describe ---------------
def worst_contact(f, keep):
    """Per patch: the index of the contact that fails the deletion test worst (-1: none),
    and what is wrong with it, in words.  The test: the contact's three residuals in the top
    jet, each over (1 - its leverage), against the patch's robust scale (their median), at
    1e-3 / n; and gross: its point GROSS_POSITION off, or its normal GROSS_ANGLE."""
    n = f.n
    r, h = pick(f.resid, f.quiet), pick(f.hat, f.quiet)
    part = r * r / (1.0 - np.minimum(h, 0.999))
    pos, slope = part[:, :n], part[:, n : 2 * n] + part[:, 2 * n :]
    stat = np.where(keep, pos + slope, np.nan)
    dof = 3 * keep.sum(-1) - np.array([size(int(o)) for o in f.quiet])
    s2 = np.nanmedian(stat, axis=-1) / 2.366  # (the median of chi^2_3)
    s2 = np.where(f.stated.all(-1), np.maximum(s2, 1.0), s2)
    s2 = np.where(np.isfinite(s2) & (s2 > 0), s2, 1.0)
    z = np.where(keep, stat / s2[:, None], -1.0)
    worst = np.argmax(z, -1)
    idx = np.arange(len(z))
    w = f.w
    off = np.abs(r[:, :n]) / np.where(w[:, :n] > 0, w[:, :n], 1.0)  # (in L)
    ds = np.hypot(r[:, n : 2 * n] / np.where(w[:, n : 2 * n] > 0, w[:, n : 2 * n], 1.0),
                  r[:, 2 * n :] / np.where(w[:, 2 * n :] > 0, w[:, 2 * n :], 1.0))  # fmt: skip
    turn = np.degrees(np.arctan(ds / (1.0 + f.g2)))  # (a slope change, as an angle)
    gross = (off[idx, worst] > GROSS_POSITION) | (turn[idx, worst] > GROSS_ANGLE)
    limit = 16.27 + 2.0 * np.log(np.maximum(keep.sum(-1), 1))
    third = -np.sort(-z, -1)[:, min(MAX_OUTLIERS, z.shape[1] - 1)]
    alone = z[idx, worst] > ISOLATED * np.maximum(third, 1.0)  # (a misfit spreads over many)
    bad = (z[idx, worst] > limit) & (dof >= 4) & gross & alone
    why = [None] * len(z)
    for b in np.flatnonzero(bad):
        k = worst[b]
        if pos[b, k] >= slope[b, k]:
            why[b] = f"its point is {off[b, k] * f.L[b]:.3g} off the surface the others describe"
        else:
            why[b] = f"its normal is {turn[b, k]:.0f} deg off the surface's there"
    return np.where(bad, worst, -1), why


def screen_normals(N, mask, max_angle):
    """Contacts whose normal is over MAX_ANGLE from the patch's mean normal (seeded at the
    medoid: the normal closest to all others) are left out, with a warning each.  A normal's
    summed agreement with all the others, sum_j n_i . n_j, is n_i . (sum_j n_j): one pass
    over the rows, no n x n matrix."""
    cosmax = math.cos(math.radians(max_angle))
    medoid = np.argmax(np.where(mask, mv(N, vm(mask.astype(float), N)), -np.inf), axis=-1)
    seed = N[np.arange(len(N)), medoid]
    near = mask & (mv(N, seed) > cosmax)
    mean = unit(vm(near.astype(float), N))
    cos = mv(N, mean)
    keep = mask & (cos > cosmax)
    warnings = [[] for _ in range(len(N))]
    for b, k in zip(*np.nonzero(mask & ~keep), strict=True):
        angle = math.degrees(math.acos(max(-1.0, min(1.0, float(cos[b, k])))))
        warnings[b].append(
            f"contact {k} left out: its normal is {angle:.0f} deg from its neighbours' "
            f"(limit {max_angle:g} deg, --max-normal-angle)"
        )
    return keep, warnings


# --- 8. Do a patch's positions and normals describe one surface? (thesis §4.5 fits both at
# once, and so assumes they do.)
#
# Normals given in the wrong frame, flipped, or read off a flat plate describe another surface
# than the contacts' positions, and a joint fit follows whichever rows its noise estimate trusts
# more, confidently. So the normals alone are fitted by a 2-jet of slopes, and the surface it
# describes (up to a constant) is compared with the positions in data space: they disagree where
# the positions' rms gap to it exceeds ``MIN_RATIO`` times its expected size (the positions' own
# 2-jet residual and the normals' surface's prediction noise) and ``MIN_GAP`` plus the gap the
# answer's own jet makes (a curvature changing over the patch, its cubic terms, puts positions
# and slopes apart in the two 2-jets by itself; not its quartic, which on three lines can
# reconcile flipped normals with the positions exactly). A data-space test cannot be fooled by
# a layout that leaves the positions' own curvature ill-determined. On the tune split of the
# families bench: 2 consistent patches of 7,824 refused, none of 2,640 with outliers; 20 of 21
# inconsistent reproducers refused (tests).


REDUNDANCY = 1.5  # rows per term of each fit alone
MIN_RATIO = 5.0  # the positions' rms gap to the normals' surface, in its expected sizes
MIN_GAP = 2e-3  # of L: a smaller gap is no evidence of anything
TINY = 1e-30


def disagreements(xy, heights, slopes, keep, axes, scale, model=None):
    """Per patch None, or the line saying how positions and normals disagree.  xy (B, n, 2)
    and heights (B, n) in the frame / L, slopes (B, n, 2), keep (B, n), axes (B, 3, 3),
    scale (B,) = L.  ``model`` (B, p): the answer's jet (about the centre), or None: the gap
    its own heights and slopes leave between the two 2-jets (its terms beyond the second
    order: a curvature changing over the patch) is added to the floor ``MIN_GAP``."""
    n_kept = keep.sum(-1)
    out = [None] * len(keep)
    idx = np.flatnonzero(REDUNDANCY * size(2) <= n_kept)
    if not len(idx):
        return out
    xy, z, s, w = xy[idx], heights[idx], slopes[idx], keep[idx].astype(float)
    z, s = np.stack([z, 0 * z], -1), np.stack([s, 0 * s], -1)  # (the data, the model's)
    p = 0 if model is None else model.shape[1]
    V, DX, DY = design(xy[..., 0], xy[..., 1], next(o for o in range(2, 9) if size(o) >= p))
    if model is not None:  # (the 2-jet's rows below: the leading columns)
        z[..., 1] = mv(V[..., :p], model[idx])
        s[..., 0, 1], s[..., 1, 1] = mv(DX[..., :p], model[idx]), mv(DY[..., :p], model[idx])
    V, DX, DY = (np.ascontiguousarray(v[..., : size(2)]) for v in (V, DX, DY))
    tp, _, _, rp, okp = _fit(V * w[..., None], z * w[..., None])
    A = np.concatenate([DX, DY], 1)[..., 1:] * np.tile(w, 2)[..., None]
    sn = np.concatenate([s[:, :, 0], s[:, :, 1]], 1) * np.tile(w, 2)[..., None]
    tn, Cn, s2, _, okn = _fit(A, sn)
    pred = np.einsum("bnp,bpk->bnk", V[..., 1:], tn)  # the normals' surfaces, up to a constant
    gap = (z - pred) * w[..., None]
    gap = (gap - (gap.sum(1) / n_kept[idx, None])[:, None]) * w[..., None]
    rms = np.sqrt(np.sum(gap * gap, 1) / n_kept[idx, None])
    rms_model = rms[:, 1]
    gap, rms, rp, s2 = gap[..., 0], rms[:, 0], rp[..., 0], s2[:, 0]
    var_p = np.sum(rp * rp, -1) / np.maximum(n_kept[idx] - size(2), 1)
    var_pred = np.einsum("bnp,bpq,bnq->bn", V[..., 1:], Cn, V[..., 1:]) * s2[:, None]
    stat = np.sum(gap * gap / (var_p[:, None] + var_pred + TINY), -1) / n_kept[idx]
    bad = okp & okn & (stat > MIN_RATIO**2) & (rms > MIN_GAP + rms_model)
    for k in np.flatnonzero(bad):
        out[int(idx[k])] = _verdict(tp[k, :, 0], tn[k, :, 0], float(rms[k]), axes[idx[k]],
                                    float(scale[idx[k]]))  # fmt: skip
    return out


def _fit(A, b):
    """(coef[first 5 after any constant] (B, 5, k), their covariance over the noise variance
    (B, 5, 5), the noise variance (B, k) from the residuals, the residuals (B, m, k),
    determined (B,)) of least squares A c = b for a stack, k right-hand sides at once."""
    cn = np.sqrt(np.einsum("bij,bij->bj", A, A))
    cn = np.where(cn > 0, cn, 1.0)
    _, d, Rinv, Q = _qr(A, cn)  # (Q as X R^-1 where the fit is not stiff)
    tiny = ~(d > 1e-9 * d.max(-1, keepdims=True))  # (a patch not determined: not compared)
    qb = np.swapaxes(Q, -1, -2) @ b
    resid = b - Q @ qb
    rows = np.any(A != 0, -1)
    dof = np.maximum(rows.sum(-1) - A.shape[2], 1)
    s2 = np.sum(resid * resid, 1) / dof[:, None]
    Rinv = Rinv / cn[:, :, None]
    coef = Rinv @ qb
    cov = Rinv @ np.swapaxes(Rinv, -1, -2)
    lo = A.shape[2] - 5
    return coef[:, lo:], cov[:, lo:, lo:], s2, resid, ~tiny.any(-1)


def _verdict(tp, tn, rms, axes, L):
    """The line: where the two surfaces' curvatures differ most, or their tilt."""
    Hp, Hn = (np.array([[t[2], t[3]], [t[3], t[4]]]) for t in (tp, tn))
    lam, vec = np.linalg.eigh(Hp - Hn)
    u = vec[:, int(np.argmax(np.abs(lam)))]
    kp, kn = -(u @ Hp @ u) / L, -(u @ Hn @ u) / L  # k = -z'' (convex toward +z: k > 0)
    tilt = math.degrees(math.atan(float(np.linalg.norm(tp[:2] - tn[:2]))))
    along = ", ".join(f"{v:.2f}" for v in u @ axes[:2])
    return (
        f"positions and normals disagree: the positions lie {rms:.2g} of the patch size (rms) "
        f"off the surface the normals describe (curvature along ({along}) {kp:.3g} from the "
        f"positions vs {kn:.3g} from the normals, 1/unit; tilt {tilt:.0f} deg); check the "
        "normals' sign and frame, or take a smaller patch where the surface bends this much"
    )


def refuse_disagreeing(stack):
    """Refuse the patches whose positions and normals describe different surfaces."""
    live = np.array([b for b, why in enumerate(stack.reason) if why is None], int)
    if not len(live):
        return
    whys = disagreements(
        stack.xy[live], stack.heights[live], stack.slopes[live], stack.keep[live],
        stack.axes[live], stack.scale[live], stack.coef[live, : size(3)],  # (at most cubic)
    )  # fmt: skip
    for b, why in zip(live.tolist(), whys, strict=True):
        stack.reason[b] = why
