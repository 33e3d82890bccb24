"""The crease, tilt and curvature-jump checks' screens for a stack of patches of one size.

``edges.check``, ``tilt.untilt``, ``curvature_jump.find_jump`` and ``edges.check_answer``
look at one patch at a time; on smooth data nearly every patch passes them.  ``clear``,
``no_turn`` and ``no_jump`` (``curvature_jump``'s, with the margins and stacked fits these
share) compute, for a stack of like-sized prepared patches, the numbers those checks decide
on (the normals' gate and the step against the smooth field, the normal screen's far
contacts, the loose edge's turn; the tilt's fit, its chi^2, size and standard error; the
jump's tests) with stacked NumPy (``eigh``, QR, Gram-Schmidt, normal equations under a
condition bound) and say which patches pass each check by a margin (``REL``, ``ABS``) far
beyond the two computations' round-off.  Only the others run the per-patch check, so the
answers are the per-patch checks' exactly: a patch near a threshold, with tied normals or an
ill-conditioned fit is always checked one at a time."""

import numpy as np

from tactile.ep2 import edges, tilt
from tactile.ep2.curvature_jump import ABS, REL, no_jump, qr_fit  # noqa: F401 (no_jump: here with the others)
from tactile.ep2.curvature_jump import solve_stacked as _solve
from tactile.ep2.curvature_jump import tangent_bases as _across

TILT_COND = 1e4  # the tilt's weighted fit's MAX_COND (its rows' scales differ)
TILT_REL = 1e-3  # the tilt's margin: its fit's inverse is less accurate than the rest
TURN_TOL = 1e-6  # deg: the faces' turn's round-off, an arccos near 1 included
SEED_ROWS = 64  # contacts up to which every seed of the normal screen that ties is tried


def screens(points, normals, opts):
    """(edges clear, tilt clear, turn clear) (B,) each, for ``points``, ``normals`` (B, n, 3)
    of prepared patches (centred, unit normals) with options ``opts`` (``JetOptions``, one per
    patch): whether ``edges.check`` passes (raises nothing), whether ``tilt.untilt`` leaves
    the patch as it is, and whether ``edges.find``, loose, surely finds no edge (then
    ``edges.check_answer`` has nothing to say of a ``plane`` or a refusal)."""
    noise_pos, noise_normal = _noise(opts, "noise_pos"), _noise(opts, "noise_normal")
    cosmax = np.cos(np.radians([o.max_normal_angle for o in opts]))
    strict, loose = _no_edges(points, normals, noise_normal)
    tilt_ok = _no_tilt(points, normals, noise_pos, noise_normal)
    return strict & _few_far(normals, cosmax), tilt_ok, loose


def clear(points, normals, opts):
    """(edges clear (B,), tilt clear (B,)): ``screens``' first two."""
    return screens(points, normals, opts)[:2]


def no_turn(points, normals, opts):
    """(B,) whether ``edges.find``, loose, surely finds no edge, by the margins: it stops at
    its gate (too few contacts, or every normal within ``edges.GATE_DEG`` of the mean), or
    its faces' turn fails its tests (``_turn_fails``).  ``opts`` as ``clear`` takes them."""
    return _no_edges(points, normals, _noise(opts, "noise_normal"))[1]


def _noise(opts, key):
    """(B,) the options' stated noise ``key``, NaN where not stated."""
    return np.array([np.nan if (v := getattr(o, key)) is None else v for o in opts], float)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _gate(N):
    """(``edges.find``'s gate passed by ``ABS``, the normals' sum, its length) (B,) each."""
    total = N.sum(axis=1)
    size = np.linalg.norm(total, axis=-1)
    low = np.einsum("bnk,bk->bn", N, total).min(axis=1)
    return low - np.cos(np.radians(edges.GATE_DEG)) * size > ABS * size, total, size


def _no_edges(P, N, noise):
    """(strict, loose) (B,) each: whether ``edges.find`` surely finds no edge, strict (every
    normal near the mean (the gate), the best step not under ``STEP_RATIO`` of the smooth
    field's residual and a side's normals scattered beyond flat faces' (``edges.flat_faces``),
    or the faces' turn failing its tests (``_turn_fails``: then the loose find's too)) and
    loose (the gate, or the turn's tests with the loose one)."""
    B, n, _ = P.shape
    if n < edges.MIN_POINTS:
        return np.ones(B, bool), np.ones(B, bool)
    gate, total, size = _gate(N)
    strict, loose = gate.copy(), gate & (size > 1e-3)  # (normals in the gate sum to about n)
    todo = np.flatnonzero(~gate & (size > 1e-6))
    if todo.size:
        cuts = _cuts(N[todo])
        turn_strict, loose[todo] = _turn_fails(cuts, N[todo], noise[todo])
        strict[todo] = _step_loses(P[todo], N[todo], total[todo] / size[todo, None], cuts)
        strict[todo] |= turn_strict
    return strict, loose


def _step_loses(P, N, m, cuts):
    """``edges.find``'s ``rss_step > STEP_RATIO * smooth rss`` and not flat faces, by the
    margins (else False); ``cuts``: ``_cuts(N)``."""
    n = P.shape[1]
    sure, c1, left, right, j, k, rss_step = cuts
    sure = sure & _scattered(c1, left, right, j, k)  # (not in place: ``cuts`` is shared)
    t1, t2 = _across(m)
    xy = np.stack([np.einsum("bnk,bk->bn", P, t) for t in (t1, t2)], axis=-1)
    xy = xy - xy.mean(axis=1, keepdims=True)
    xy = xy / np.maximum(np.ptp(xy, axis=(1, 2)), 1e-300)[:, None, None]
    u, v = xy[..., 0], xy[..., 1]
    A = np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)
    coef, ok = _solve(A, N)
    sure &= ok  # (a coefficient off the least squares' only adds to rss_smooth: the safe side)
    rss_smooth = np.sum((N - A @ coef) ** 2, axis=(1, 2))
    bound = edges.STEP_RATIO * rss_smooth * (1 + REL) + ABS * n
    return sure & (rss_step > bound)


def _cuts(N):
    """``edges.find``'s best cut (``edges._best_cut``) of normals N (B, n, 3) along their
    main axis, stacked: (whether the axis and the order along it are sure, the sorted
    normals' cumulative sums, each cut's rss left and right, the best cut's index j into
    the cuts k, its rss)."""
    n = N.shape[1]
    C = _gram(N - N.mean(axis=1, keepdims=True)) / (n - 1)
    w, V = np.linalg.eigh(C)
    x = np.einsum("bnk,bk->bn", N, V[:, :, -1])
    order = np.argsort(x, axis=1)
    xs = np.take_along_axis(x, order, axis=1)
    gap = np.diff(xs, axis=1).min(axis=1)
    sure = (w[:, -1] - w[:, -2] > REL * w[:, -1]) & (gap > REL * np.ptp(x, axis=1))
    gs = np.take_along_axis(N, order[..., None], axis=1)
    c1 = np.cumsum(gs, axis=1)
    c2 = np.cumsum(np.sum(gs**2, axis=2), axis=1)
    k = np.arange(1, n)
    left = c2[:, :-1] - np.sum(c1[:, :-1] ** 2, axis=2) / k
    right = (c2[:, -1:] - c2[:, :-1]) - np.sum((c1[:, -1:] - c1[:, :-1]) ** 2, axis=2) / (n - k)
    ok = (k >= edges.MIN_SIDE) & (n - k >= edges.MIN_SIDE)
    rss = np.where(ok, left + right, np.inf)
    j = np.argmin(rss, axis=1)
    return sure, c1, left, right, j, k, rss[np.arange(len(j)), j]


def _turn_fails(cuts, N, noise):
    """(strict, loose) (B,) each: whether ``edges.find`` surely finds no edge past its gate
    for its faces' turn: its best cut (``cuts``: ``_cuts(N)``; sure, and the next best
    ``REL`` of the normals' count behind) has faces turning under ``MIN_TURN_DEG`` or over
    ``MAX_TURN_DEG``, or under ``MIN_Z`` standard errors (noise at least ``noise`` (B,),
    NaN: none); loose, or under ``LOOSE_SCATTER`` scatters of a normal."""
    e, (B, n, _) = edges, N.shape
    sure, c1, left, right, j, k, best = cuts
    rss = np.where((k >= e.MIN_SIDE) & (n - k >= e.MIN_SIDE), left + right, np.inf)
    rss[np.arange(B), j] = np.inf
    sure = sure & (rss.min(axis=1) - best > REL * n)  # (not in place: ``cuts`` is shared)
    b, kj = np.arange(B), k[j]
    n1 = _unit(c1[b, j] / kj[:, None])
    n2 = _unit((c1[b, -1] - c1[b, j]) / (n - kj)[:, None])
    turn = np.degrees(np.arccos(np.clip(np.sum(n1 * n2, axis=1), -1.0, 1.0)))
    lo, hi = turn * (1 - REL) - TURN_TOL, turn * (1 + REL) + TURN_TOL
    s2 = np.fmax(np.maximum(best - ABS * n, 0.0) / (2 * n - 4), noise**2)  # (the least it is)
    se = np.degrees(np.sqrt(s2 * (1 / kj + 1 / (n - kj))))
    none = (hi < e.MIN_TURN_DEG) | (lo > e.MAX_TURN_DEG) | (hi < e.MIN_Z * se * (1 - REL))
    scatter = hi < e.LOOSE_SCATTER * np.degrees(np.sqrt(s2)) * (1 - REL)
    return sure & none, sure & (none | scatter)


def _scattered(c1, left, right, j, k):
    """Whether a side of the best cut (index ``j`` into the cuts ``k``) surely scatters over
    ``edges.TIGHT`` of the step between the sides' means: ``edges.flat_faces`` is False."""
    b = np.arange(len(j))
    kj = k[j]
    n = k[-1] + 1
    m1 = c1[b, j] / kj[:, None]
    m2 = (c1[b, -1] - c1[b, j]) / (n - kj)[:, None]
    step = np.linalg.norm(m2 - m1, axis=1)
    rms = np.sqrt(np.maximum(np.maximum(left[b, j] / kj, right[b, j] / (n - kj)), 0.0))
    return rms > edges.TIGHT * step * (1 + REL) + ABS


def _few_far(N, cosmax):
    """Whether ``edges.check``'s normal screen surely leaves out at most ``MAX_LEFT_OUT``."""
    dots = np.einsum("bnk,bk->bn", N, N.sum(axis=1))
    seed = np.argmax(dots, axis=1)
    if N.shape[1] <= SEED_ROWS:
        seeds = N @ np.swapaxes(N, -1, -2) - cosmax[:, None, None]  # (seed n, contact m)
        near = seeds[np.arange(len(N)), seed]
        sure = _same_near(dots, seeds, near)
    else:  # (a seed that ties the next: left to the check)
        top = np.sort(dots, axis=1)[:, -2:]
        near = np.einsum("bnk,bk->bn", N, N[np.arange(len(N)), seed]) - cosmax[:, None]
        sure = top[:, 1] - top[:, 0] > REL * np.abs(dots).max(axis=1)
        sure &= np.all(np.abs(near) > REL, axis=1)
    mean = _unit(np.einsum("bn,bnk->bk", (near > 0).astype(float), N))
    cos = np.einsum("bnk,bk->bn", N, mean)
    sure &= np.all(np.abs(cos - cosmax[:, None]) > REL, axis=1)
    far = np.sum(cos <= cosmax[:, None], axis=1)
    return sure & (far <= edges.MAX_LEFT_OUT)


def _same_near(dots, seeds, near):
    """Whether the contacts near the seed (``near``, (B, n): each one's cosine to it less
    the limit's) are surely those near the check's seed: every contact whose dot with the
    normals' sum ties the largest (the check's argmax, to round-off) puts, as the seed
    (``seeds`` (B, n, n)), the same contacts near, each by ``REL``.  Noise-free patches
    laid out symmetrically tie."""
    scale = np.abs(dots).max(axis=1, keepdims=True)
    tied = dots >= dots.max(axis=1, keepdims=True) - REL * scale
    same = np.all(np.abs(seeds) > REL, axis=2) & np.all((seeds > 0) == (near > 0)[:, None], 2)
    return np.all(same | ~tied, axis=1)


def _no_tilt(P, N, noise_pos, noise_normal):
    """Whether ``tilt.untilt`` surely names no tilt (``tilt.estimate``'s fit, stacked)."""
    B, n, _ = P.shape
    out = np.zeros(B, bool)
    if n < tilt.MIN_POINTS:
        return ~out
    total = N.sum(axis=1)
    size = np.linalg.norm(total, axis=-1)
    live = np.flatnonzero(size > 1e-6)
    if not live.size:
        return out
    P, N, noise_pos, noise_normal = P[live], N[live], noise_pos[live], noise_normal[live]
    m = total[live] / size[live, None]
    R = np.stack([*_across(m), m], axis=1)  # rows: x, y, z
    local = (P - P.mean(axis=1, keepdims=True)) @ R.transpose(0, 2, 1)
    L = np.maximum(np.ptp(local[..., 0], axis=1), np.ptp(local[..., 1], axis=1))
    nl = N @ R.transpose(0, 2, 1)
    zmin = nl[..., 2].min(axis=1)
    sure = L > ABS * np.abs(P).max(axis=(1, 2))
    steep = sure & (zmin < 0.1 - REL)  # ``estimate``: a normal near the tangent plane
    sure &= steep | (zmin > 0.1 + REL)
    Ls = np.where(sure, L, 1.0)
    x, y, z = (local / Ls[:, None, None]).transpose(2, 0, 1)
    nz = np.where(nl[..., 2] > 0.05, nl[..., 2], 1.0)  # (only where none is under 0.1)
    sx, sy = -nl[..., 0] / nz, -nl[..., 1] / nz
    one, zero = np.ones_like(x), np.zeros_like(x)
    H = np.stack([one, x, y, x * x / 2, x * y, y * y / 2, zero, zero], axis=-1)
    Sx = np.stack([zero, one, zero, x, y, zero, one, zero], axis=-1)
    Sy = np.stack([zero, zero, one, zero, x, y, zero, one], axis=-1)
    sp, ok = _qr_residual(H[..., :6], z, n - 6)  # (sweeps' quadratic columns: cond ~ 1e3)
    sp = np.fmax(sp, noise_pos / Ls)  # (NaN where not stated: the residual alone)
    sure &= ok
    r, ok = _residual(H[..., :3], np.stack([sx, sy], axis=-1), n - 3)
    sn = np.fmax(np.hypot(r[:, 0], r[:, 1]) / np.sqrt(2), noise_normal)
    sure &= ok
    sp, sn = np.maximum(sp, tilt.NOISE_FLOOR), np.maximum(sn, tilt.NOISE_FLOOR)
    A = np.concatenate([H / sp[:, None, None], Sx / sn[:, None, None], Sy / sn[:, None, None]], 1)
    b = np.concatenate([z / sp[:, None], sx / sn[:, None], sy / sn[:, None]], axis=1)
    rhs = np.concatenate([A.transpose(0, 2, 1) @ b[..., None], np.zeros((len(A), 8, 8))], -1)
    rhs[:, np.arange(8), 1 + np.arange(8)] = 1.0  # [A^T b | I]: the solution and the inverse
    sol, ok = _solve(A, None, rhs, TILT_COND)
    sure &= ok
    coef, inv = sol[..., 0], sol[..., 1:]
    chi2 = np.sum(((A @ coef[..., None])[..., 0] - b) ** 2, axis=1) / max(3 * n - 8, 1)
    cov = inv[:, 6:, 6:] * np.maximum(chi2, 1.0)[:, None, None]
    tb = coef[:, 6:]
    big = np.hypot(tb[:, 0], tb[:, 1])
    u = tb / np.maximum(big, 1e-300)[:, None]
    se = np.sqrt(np.maximum(np.einsum("bi,bij,bj->b", u, cov, u), 0.0))
    deg = np.degrees(np.arctan(big))
    none = chi2 > tilt.MAX_CHI2 * (1 + TILT_REL)
    none |= (deg < tilt.MIN_DEG * (1 - TILT_REL)) | (deg > tilt.MAX_DEG * (1 + TILT_REL))
    none |= big < tilt.MIN_Z * se * (1 - TILT_REL)
    out[live] = steep | sure & none
    return out


def _gram(A):
    return A.transpose(0, 2, 1) @ A


def _residual(A, y, dof):
    """(rms residual (B,) or (B, m) of y (B, n) or (B, n, m) fitted by A's columns, with
    ``dof`` spare rows; ``_solve``'s ok) per patch."""
    Y = y if y.ndim == 3 else y[..., None]
    coef, ok = _solve(A, Y)
    rms = np.sqrt(np.sum((A @ coef - Y) ** 2, axis=1) / max(dof, 1))
    return (rms if y.ndim == 3 else rms[:, 0]), ok


def _qr_residual(A, y, dof):
    """``_residual`` of y (B, n) by Householder QR (``curvature_jump.qr_fit``: within about
    cond(A) eps of ``np.linalg.lstsq``'s, the normal equations' cond^2 eps), and its ok."""
    _, _, rss, ok = qr_fit(A, y[..., None])
    return np.sqrt(rss / max(dof, 1)), ok
