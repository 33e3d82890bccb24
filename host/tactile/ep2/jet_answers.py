"""The default fit's answer for a stack (docs/ep2.md, "The default", steps 5-7 and 9).

``answer`` (steps 5-7, from one pass of ``local_jet.fit``, ``JetFit``): the 2-jet moved
toward the jet below the top on evidence, its covariance of noise plus the bias left (the
Wald test of two jets' difference, the positive part of a measured bias, and the size of
the terms a jet leaves out, from a sphere's or cylinder's of the measured curvature), the
curvature at the centre and whether the contacts lie on one line: a ``JetStack``.

``outcomes`` (step 9): from a ``JetStack`` to each patch's ``centre_result.Answer``, or the
refusal in its place.  A patch is refused only when its fit says so (too few consistent
contacts, one line, no quadric through them, positions and normals that disagree:
``local_jet.disagreements``), or when the noise covariance of its 2-jet's curvature leaves
a direction undetermined, named in world coordinates: a 95 % half-width over
``MAX_HALF_WIDTH`` / L.  The bias left widens the intervals; it refuses nothing.
Otherwise: the headline curvature, intervals and label at the patch centre
(``centre_result.summary``) and the thesis's grid statistics (§4.8.2,
``geometry.grid_stats``).
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import centre_result, geometry
from tactile.ep2.centre_result import Answer
from tactile.ep2.geometry import DERIVS, design, mv, pick, size, vm
from tactile.errors import DataError

MAX_HALF_WIDTH = 0.25  # of 1/L: the 2-jet's noise half-width (95 %) beyond which k is unknown


def outcomes(stack, jet, names=None):
    """A list per patch of ``stack``: its ``centre_result.Answer``, or the ``DataError``
    refusing it.  ``jet``: the ``JetOptions`` (``grid``, ``intervals``); ``names``: per
    patch, how to name its contacts (``patch_input.row_names``) or None."""
    B = len(stack.scale)
    names = [None] * B if names is None else names
    out = [None] * B
    live = [b for b in range(B) if stack.reason[b] is None]
    for b in range(B):
        if stack.reason[b] is not None:
            out[b] = DataError(_name_rows(stack.reason[b], names[b]) + _left(stack, b, names[b]))
    if live:
        for b in np.asarray(live)[_wide(stack, live)].tolist():
            out[b] = DataError(undetermined(stack, b) + _left(stack, b, names[b]))
    ok = np.array([b for b in live if out[b] is None], int)
    if not len(ok):
        return out
    heads = centre_result.summary(
        stack.t[ok], stack.cov[ok], None, stack.scale[ok], jet.intervals,
        np.zeros_like(stack.cov[ok]),  # (k1, k2 as fitted: debiasing them cost RMS S)
    )  # fmt: skip
    ch, gx, gy = channels(stack, ok, jet.grid)
    stats = geometry.grid_stats(ch, stack.scale[ok], [c.shape == "plane" for c in heads])
    zx, zy, zxx, zxy, zyy = np.moveaxis(stack.coef[ok][:, 1:6], -1, 0)
    dir1 = np.asarray(geometry.principal(zx, zy, zxx, zxy, zyy)["dir1"], float)
    d1 = np.einsum("bi,bij->bj", dir1, stack.axes[ok])
    xy = stack.xy[ok] + stack.centre[ok][:, None, :]
    keep = stack.keep[ok][..., None]
    box = np.concatenate([np.where(keep, xy, np.inf).min(1), np.where(keep, xy, -np.inf).max(1)],
                         -1)[:, [0, 2, 1, 3]].tolist()  # fmt: skip
    order = _order_of(stack.coef.shape[1])
    # Python numbers for the stack at once (``tolist``: the same values as float(a[b]))
    scale, jet, noise = stack.scale.tolist(), stack.order.tolist(), stack.noise.tolist()
    stated = stack.stated.any(-1).tolist()
    weight, top = stack.weight.tolist(), stack.top.tolist()
    # each patch's rows as views (``list`` of an array: no fancy index a patch)
    coefs, centres, origins, axes = (
        list(a) for a in (stack.coef, stack.centre, stack.origin, stack.axes)
    )
    grids = zip(*(list(c) for c in ch), list(gx), list(gy), list(d1), strict=True)
    for k, (b, head, (*chk, gxk, gyk, d1k)) in enumerate(
        zip(ok.tolist(), heads, grids, strict=True)
    ):
        out[b] = Answer(
            head, stats[k], _model_text(weight[b], top[b]), jet[b],
            "stated" if stated[b] else "auto", *noise[b],
            geometry.PatchFrame(origins[b], axes[b]), scale[b],
            _surface(centres[b], order, coefs[b]),
            (chk, gxk, gyk), d1k, tuple(box[k]),
            [_name_rows(w, names[b]) for w in stack.warnings[b]] if stack.warnings[b] else [],
        )  # fmt: skip
    return out


def _surface(c, order, coef):
    """z(q) of the jet ``coef`` about the centre ``c`` (frame, / L), q (m, 2)."""
    return lambda q: design(q[:, 0] - c[0], q[:, 1] - c[1], order)[0] @ coef


def _left(stack, b, names, most=2):
    """'; ' and the contacts patch b left out (the first ``most``, then how many more)."""
    left = [_name_rows(w, names) for w in stack.warnings[b]]
    more = f"; and {len(left) - most} more left out" if len(left) > most + 1 else ""
    return "".join(f"; {w}" for w in left[: most if more else None]) + more


def _half_widths(cov):
    """(B,) the 95 % half-width of the curvature in its worst direction (cov (B, 3, 3))."""
    finite = np.all(np.isfinite(cov), axis=(1, 2))
    w = np.linalg.eigvalsh(np.where(finite[:, None, None], cov, 0.0))[:, -1]
    return np.where(finite, 1.96 * np.sqrt(np.maximum(w, 0.0)), np.inf)


def _wide(stack, idx):
    """(b,) whether the noise of the 2-jet leaves a direction's curvature undetermined."""
    return _half_widths(stack.cov_quadric[idx]) > MAX_HALF_WIDTH


def undetermined(stack, b):
    """Why patch b's curvature is not determined (its worst direction, world coordinates)."""
    cov, scale = stack.cov_quadric[b], float(stack.scale[b])
    half = _half_widths(cov[None])[0]
    # curvature along u = (cos th, sin th): a cos^2 + 2 b cos sin + c sin^2; its worst th
    th = np.linspace(0.0, np.pi, 181)[:-1]
    u = np.stack([np.cos(th) ** 2, 2 * np.cos(th) * np.sin(th), np.sin(th) ** 2])
    worst = th[int(np.argmax(np.einsum("in,ij,jn->n", u, np.nan_to_num(cov), u)))]
    d = np.cos(worst) * stack.axes[b][0] + np.sin(worst) * stack.axes[b][1]
    return (
        f"curvature along {centre_result.direction_text(d)} is not determined: its 95 %"
        f" interval is +/- {half / scale:.3g} per unit length, over {MAX_HALF_WIDTH:g}/L"
        f" (L = {scale:.4g}); the contacts do not span that direction well: sweep across it"
    )


def channels(stack, idx, n):
    """(zx, zy, zxx, zxy, zyy) of each patch's answer on an n x n grid over its contacts' box
    (frame, / L), each (b, n^2), and the grid's x, y (b, n^2)."""
    xy, keep, centre = stack.xy[idx], stack.keep[idx], stack.centre[idx]
    lo = np.where(keep[..., None], xy, np.inf).min(1)
    hi = np.where(keep[..., None], xy, -np.inf).max(1)
    xs = np.linspace(lo[:, 0], hi[:, 0], n, axis=-1)
    ys = np.linspace(lo[:, 1], hi[:, 1], n, axis=-1)
    gx, gy = np.repeat(xs, n, axis=-1), np.tile(ys, (1, n))  # about the centre
    coef = stack.grid_coef[idx]  # (the best-supported jet: ``_grid_coef``)
    order = _order_of(coef.shape[1])
    # on a tensor grid the jet is px C py^T, C[i, j] the coefficient of x^i y^j / (i! j!)
    C = np.zeros((len(idx), order + 3, order + 3))
    for k, (i, j) in enumerate(geometry.exponents(order)):
        C[:, i, j] = coef[:, k]
    px = np.stack(geometry.powers(xs, order), -1)
    pyT = np.swapaxes(np.stack(geometry.powers(ys, order), -1), -1, -2)
    ch = [(px @ C[:, a : a + order + 1, c : c + order + 1] @ pyT).reshape(len(idx), -1)
          for a, c in DERIVS]  # fmt: skip
    return ch, gx + centre[:, :1], gy + centre[:, 1:]


def _order_of(p):
    o = 0
    while size(o) < p:
        o += 1
    return o


def _model_text(w, top):
    """One line: the jet the answer is (moved ``w`` of the way from the 2-jet), what checked
    it (the ``top``-jet)."""
    hi = top - 1 if top >= 4 else top
    moved = f", moved {w:.2f} of the way to the {hi}-jet" if hi > 2 else ""
    return (f"2-jet of positions and normals{moved}; truncation checked against the "
            f"{top}-jet")  # fmt: skip


def _name_rows(why, names):
    """A line naming 'contact k' (k as fitted) names it as the user numbered it: ``names``
    (``patch_input.row_names``) or, None, as it is."""
    if names is not None and "contact " in why:
        k = int(why.split("contact ")[1].split()[0].rstrip(":"))
        why = why.replace(f"contact {k} ", f"{names[k]} ", 1)
        why = why.replace(f"contact {k}:", f"{names[k]}:", 1)
    return why


SHRINK = 20.0  # the answer leaves the 2-jet only on this many times the test's dof
BIAS_EVIDENCE = 4.0  # a measured bias counts beyond this many times its own noise
CARRY_EVIDENCE = 100.0  # the grid takes the top jet on this many times the test's dof
LINE_WIDTH = 0.01  # of L: contacts spread less across their line are on one line
LINE_NOISE = 3.0  # ... as are contacts within this many position sigmas of a line
LINE_THIN = 0.05  # (of L) where that is also this thin (an outlier left in inflates sigma)


@dataclass
class JetStack:
    """What ``fit`` found for each patch of a stack (B patches); lengths / L unless said."""

    t: np.ndarray  # (B, 3) shape-operator entries at the centre
    cov: np.ndarray  # (B, 3, 3) of t: noise and bias left (intervals, tests)
    cov_noise: np.ndarray  # (B, 3, 3) of t: noise alone
    cov_quadric: np.ndarray  # (B, 3, 3): the 2-jet's noise alone (what the data determine)
    coef: np.ndarray  # (B, p_top) the answer's jet (zeros beyond its order)
    grid_coef: np.ndarray  # (B, p_top) the jet of the grid's maps: the best-supported one
    order: np.ndarray  # (B,) the jet the answer leans on (2 unless it moved over halfway)
    top: np.ndarray  # (B,) the highest order the contacts determine
    weight: np.ndarray  # (B,) how far the answer moved from the 2-jet to the higher jet
    noise: np.ndarray  # (B, 2) sigma_p (input unit) and sigma_n (rad) the weights used
    stated: np.ndarray  # (B, 2) whether noise_pos, noise_normal were stated
    origin: np.ndarray  # (B, 3) frame origin (world)
    axes: np.ndarray  # (B, 3, 3) rows: the frame's x, y, z in world coordinates
    scale: np.ndarray  # (B,) L
    centre: np.ndarray  # (B, 2) the box middle in the frame (/ L)
    xy: np.ndarray  # (B, n, 2) contacts in the frame, about the centre (/ L)
    heights: np.ndarray  # (B, n) their heights in the frame (/ L)
    slopes: np.ndarray  # (B, n, 2) their slopes from the normals
    keep: np.ndarray  # (B, n) contacts used
    reason: list  # per patch: None, or why it is refused
    warnings: list = field(default_factory=list)  # per patch: list of lines


def order_fit(f, o):
    """(coef (B, p_o), cov factor F (B, p_o, p_o): coef cov = F F^T)."""
    p = size(o)
    cn = f.cn[:, :p]
    Rinv = f.Rinv[:, :p, :p]  # (the inverse of R's leading block: its leading block)
    coef = mv(Rinv, f.qb[:, :p]) / cn
    return coef, Rinv / cn[:, :, None]


def student_factor(dof):
    """(t_dof(97.5 %) / z(97.5 %))^2 per patch: the variance widening that holds 95 % where
    the noise is estimated from ``dof`` spare rows (a few contacts leave few), at most 16."""
    return np.minimum((geometry.t975(dof) / geometry.Z975) ** 2, 16.0)


def answer(f, keep, reason, warnings, stated):
    """The ``JetStack`` of the final fit (the module docstring)."""
    B, top = len(keep), f.top
    hi = np.where(top >= 4, top - 1, top)
    orders = range(2, int(top.max()) + 1)
    theta, cov, coefs = {}, {}, {}
    for o in orders:
        c, F = order_fit(f, o)
        coefs[o], theta[o] = c, c[:, 1:6]
        cov[o] = F[:, 1:6] @ np.swapaxes(F[:, 1:6], -1, -2)
    rt = pick(f.resid, top)
    dof = 3 * keep.sum(-1) - np.array([size(int(o)) for o in top])
    s2 = np.sum(rt * rt, -1) / np.maximum(dof, 1)
    s2 = np.maximum(np.where(dof > 0, s2, 1.0), 1.0)  # (never below the weights' noise)
    s2 = s2[:, None, None]
    C2, Ch, Ct = cov[2] * s2, pick(cov, hi) * s2, pick(cov, top) * s2
    t2, th, tt = theta[2], pick(theta, hi), pick(theta, top)
    d = th - t2
    d2, q = wald(d, Ch - C2)
    w = np.maximum(0.0, 1.0 - SHRINK * q / np.where(d2 > 0, d2, np.inf))
    w = np.where(hi > 2, w, 0.0)
    est = t2 + w[:, None] * d
    W = w[:, None, None]
    C_noise = (1 - W * W) * C2 + W * W * Ch
    e = est - tt  # the answer against the top jet, and that difference's own noise
    Ve = (1 - W) ** 2 * (Ct - C2) + (1 - (1 - W) ** 2) * (Ct - Ch)
    T = omitted(f, coefs, cov, top)  # (B, 5): the order above the top, at its prior size
    T2 = (1.0 - w)[:, None] * round_bias(f, coefs, cov)  # the 2-jet's, were it a sphere's
    bias = positive(e[:, :, None] * e[:, None, :] - BIAS_EVIDENCE * Ve)
    bias = np.maximum(bias, T2[:, :, None] * T2[:, None, :] * np.eye(5))  # (where unmeasured)
    C_mse = C_noise + bias + T[:, :, None] * T[:, None, :]
    coef = np.zeros((B, size(int(top.max()))))
    coef[:, :6] = coefs[2]
    ch = _pick_coef(coefs, hi, coef.shape[1])
    coef = coef + w[:, None] * (ch - coef)
    grid_coef = _grid_coef(coef, coefs, top, e, Ve)
    t, J = _entries_and_jacobian(est)
    width, line, across = _width(f.xy, keep)
    thin = line < np.minimum(LINE_NOISE * f.sig[:, 0], LINE_THIN)
    width = np.where(thin, np.minimum(width, line), width)
    for b in np.flatnonzero(f.spread == 0.0):
        reason[b] = reason[b] or (
            "all contacts at one point: the patch needs contacts spread in two directions"
        )
    one_line = (width < LINE_WIDTH) | thin
    for b in np.flatnonzero(one_line):
        v = ", ".join(f"{c:.2f}" for c in across[b] @ f.axes[b][:2])
        reason[b] = reason[b] or (
            f"the contacts lie on one line or path (their spread across it is {width[b]:.2g} of "
            f"the patch size): the curvature across ({v}) is not determined; sweep across it"
        )
    for b in np.flatnonzero(~f.ok2):
        reason[b] = reason[b] or "the contacts do not determine a quadric (2-jet) through them"
    # the intervals (not the answer): Student's t where the noise is estimated
    widen = np.where(stated.all(-1), 1.0, student_factor(dof))[:, None, None]
    cov_t = J @ C_mse @ np.swapaxes(J, -1, -2) * widen
    cov_noise = J @ C_noise @ np.swapaxes(J, -1, -2)
    cov_quadric = J @ C2 @ np.swapaxes(J, -1, -2)
    sig = f.sig * np.stack([f.L, np.ones(B)], -1)
    return JetStack(
        t=t, cov=cov_t, cov_noise=cov_noise, cov_quadric=cov_quadric, coef=coef,
        grid_coef=grid_coef,
        order=np.where(w > 0.5, hi, 2), top=top, weight=w, noise=sig, stated=stated,
        origin=f.origin, axes=f.axes,
        scale=f.L, centre=f.centre, xy=f.xy, heights=f.heights,
        slopes=f.slopes, keep=keep, reason=reason,
        warnings=warnings,
    )  # fmt: skip


def _width(xy, keep):
    """(B,) spreads of the kept contacts across their path, / L: about the parabola
    v = a + b u + c u^2 along their main line u (a straight finger path projects to a bent
    one where the frame's normal leans out of the path's plane; across such a path only the
    model, not the data, gives a curvature) and about the line itself (rms); (B, 2) the
    direction across, in the frame."""
    w = keep.astype(float)
    n = np.maximum(w.sum(-1), 1.0)[:, None]
    d = (xy - vm(w, xy)[:, None, :] / n[..., None]) * w[..., None]
    _, vecs = np.linalg.eigh(np.swapaxes(d, -1, -2) @ d)
    u, v = (d @ vecs[..., 1:])[..., 0], (d @ vecs[..., :1])[..., 0]
    V = np.stack([w, u, u * u], -1)
    Q, _ = np.linalg.qr(V)
    r = v - mv(Q, vm(v, Q))
    curve = np.sqrt(np.sum(r * r * w, -1) / np.maximum(n[:, 0] - 3.0, 1.0))
    return curve, np.sqrt(np.sum(v * v, -1) / n[:, 0]), vecs[..., 0]


def _grid_coef(coef, coefs, top, e, Ve):
    """(B, p_top): the jet whose values the grid's maps take: the top jet (4 or more) where
    the answer at the centre stands off it by more than ``CARRY_EVIDENCE`` times that
    difference's noise (the data carry the top jet: a strongly curved, nearly noise-free
    patch, where the answer's lower jet drifts off over the box), else the answer's jet."""
    d2, rank = wald(e, Ve)
    carry = (top >= 4) & (d2 > CARRY_EVIDENCE * np.maximum(rank, 1))
    if not carry.any():
        return coef
    return np.where(carry[:, None], _pick_coef(coefs, top, coef.shape[1]), coef)


def _pick_coef(coefs, which, p):
    out = np.zeros((len(which), p))
    for o, c in coefs.items():
        sel = which == o
        out[sel, : c.shape[1]] = c[sel]
    return out


def _entries_and_jacobian(theta):
    """Shape-operator entries (B, 3) of (zx, zy, zxx, zxy, zyy) and their Jacobian (B, 3, 5)
    (complex step: exact to round-off)."""
    t = np.stack(geometry.shape_entries(*np.moveaxis(theta, -1, 0)), -1)
    J = np.empty((len(theta), 3, 5))
    for k in range(5):
        z = theta.astype(complex)
        z[:, k] += 1e-30j
        J[:, :, k] = np.stack(geometry.shape_entries(*np.moveaxis(z, -1, 0)), -1).imag / 1e-30
    return t, J


def wald(d, V):
    """d^T V^+ d and V's rank, per patch (V symmetric positive semi-definite)."""
    w, U = np.linalg.eigh(V)
    big = w > 1e-9 * np.maximum(w[:, -1:], 1e-300)
    proj = vm(d, U)
    return np.sum(np.where(big, proj * proj / np.where(big, w, 1.0), 0.0), -1), big.sum(-1)


def positive(M):
    """M's positive part (symmetric): its negative eigenvalues set to 0."""
    w, U = np.linalg.eigh(0.5 * (M + np.swapaxes(M, -1, -2)))
    return (U * np.maximum(w, 0.0)[:, None, :]) @ np.swapaxes(U, -1, -2)


def omitted(f, coefs, cov, top):
    """(B, 5): how the jet's (zx, zy, zxx, zxy, zyy) would move were the order above the top
    in the data, its coefficients as large as a sphere or cylinder of the measured
    curvature makes them: a circle's derivatives are k, 3 k^3, 45 k^5, so the order
    beyond 4 is 5 z4^2 / z2 (z_j: the rms of the j-th derivatives, their noise taken out)
    and beyond 3 it is 3 z2^3."""
    B = len(top)
    out = np.zeros((B, 5))
    z2 = signal(coefs[2][:, 3:6], cov[2][:, 2:5, 2:5])
    for o in np.unique(top):
        sel = top == o
        nxt = o + 1
        cols = slice(size(o), size(nxt))
        if o >= 4:
            c4 = coefs[o][sel][:, size(3) : size(4)]
            F4 = fit_cov(f, o, sel)[:, size(3) : size(4), size(3) : size(4)]
            z4 = signal(c4, F4)
            tau = 5.0 * z4 * np.minimum(z4 / np.maximum(z2[sel], 1e-12), 12.0)
        else:
            tau = 3.0 * z2[sel] ** 3
        G = regress_omitted(f, o, cols, sel)  # (b, p_o, q)
        out[sel] = tau[:, None] * np.sqrt(np.sum(G[:, 1:6] ** 2, -1))
    return out


def round_bias(f, coefs, cov):
    """(B, 5): how far the 2-jet's values move from those of the surface whose shape operator
    is the measured Hessian H everywhere, its quartic left out: to fourth order that surface
    is z = p + p r / 8, p = x^T H x, r = x^T H^2 x (exact for spheres and cylinders; the
    spline's ``centre_result.model_bias`` uses the same surface).  Its quartic, mapped through
    the 2-jet's regression on the omitted columns, is the shift."""
    zxx, zxy, zyy = np.moveaxis(coefs[2][:, 3:6], -1, 0)
    p20, p11, p02 = zxx, 2.0 * zxy, zyy
    r20, r11, r02 = zxx * zxx + zxy * zxy, 2.0 * zxy * (zxx + zyy), zxy * zxy + zyy * zyy
    quartic = np.stack([  # derivatives at 0 (x^i y^j / (i! j!) columns) of p r / 8
        24.0 * p20 * r20, 6.0 * (p20 * r11 + p11 * r20),
        4.0 * (p20 * r02 + p11 * r11 + p02 * r20), 6.0 * (p11 * r02 + p02 * r11),
        24.0 * p02 * r02,
    ], -1) / 8.0  # fmt: skip
    G = regress_omitted(f, 2, slice(size(3), size(4)), np.ones(len(zxx), bool))
    if G.shape[-1] < 5:  # (too few contacts for a 3-jet: no quartic columns built)
        return np.zeros((len(zxx), 5))
    return np.abs(mv(G[:, 1:6], quartic))


def signal(c, C):
    """The rms of coefficients c (b, q) with their noise (cov C (b, q, q)) taken out."""
    noise = np.trace(C, axis1=-2, axis2=-1) / c.shape[-1]
    return np.sqrt(np.maximum(np.mean(c * c, -1) - noise, 0.0))


def fit_cov(f, o, sel):
    p = size(o)
    F = f.Rinv[sel][:, :p, :p] / f.cn[sel][:, :p, None]
    return F @ np.swapaxes(F, -1, -2)


def regress_omitted(f, o, cols, sel):
    """Coefficients of the omitted columns ``cols`` regressed on the order-o jet's, (b, p_o, q):
    how each omitted term, were it there with coefficient 1, moves the fit."""
    p = size(o)
    every = sel.all()  # (no copy of the stack's Q and jet where every patch is asked)
    Q, Aw = (f.Q, f.Aw) if every else (f.Q[sel], f.Aw[sel])
    Rinv, cn = f.Rinv[sel][:, :p, :p], f.cn[sel]
    X = np.swapaxes(Q[..., :p], -1, -2) @ Aw[..., cols]
    return Rinv @ X / cn[:, :p, None]
