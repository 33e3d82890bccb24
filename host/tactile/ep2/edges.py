"""Edges and creases: a patch whose contacts lie on two faces is refused, naming the edge.

Two faces meeting at an edge give normals that jump.  ``find`` cuts the contacts in two by
their normals along the direction in which these vary most, and finds an edge where the
step (two constant normals) leaves under ``STEP_RATIO`` of a smooth field's residual (a
quadratic in the patch coordinates) with each side spread across the edge (over
``MIN_DEPTH`` of the patch), or where each side's normals are flat (``flat_faces``: they
neither scatter nor turn within the side as between the sides); the normals turn by
``MIN_TURN_DEG`` to ``MAX_TURN_DEG`` (over ``MIN_Z`` standard errors) and ``MIN_APART`` of
the contacts lie on their face's side.  Each face is a plane through its contacts' centroid
with their mean normal; the edge is the planes' intersection (the point nearest the
contacts' middle, its direction n1 x n2); the dihedral angle is 180 deg less the normals'
turn, with a 95 % interval from the normals' scatter (Student t).  The direction's 95 %
half-angle (``direction_half``) carries each mean normal's error along the edge (the
normals' scatter along it over the face's count) to n1 x n2.  A ridge's faces fall away
from the edge, a valley's rise.

``check`` raises ``EdgeError`` (a ``DataError``, exit 3) naming the edge's location,
direction and dihedral angle.  Where each side is a line (or lines) along which the normals
are constant within the noise (``constant_faces``), any surface tangent to the two planes
along the lines fits as well (a cylinder through two lines along its axis): the edge they
imply is named as one reading, the layout said not to tell it from a smooth curve.  More
than ``MAX_LEFT_OUT`` normals disagreeing with the rest with no edge: a bad patch.
``check_answer`` says the same of a fitted ``plane`` whose normals turn, and makes a label
``uncertain`` across a curvature jump (``curvature_jump``).
"""

from dataclasses import dataclass

import numpy as np

from tactile.ep2 import curvature_jump
from tactile.ep2.geometry import Z975, t975
from tactile.errors import DataError

_basis = curvature_jump.tangent_basis  # (check_screens mirrors it)

STEP_RATIO = 1 / 5
MIN_SIDE = 3
MIN_POINTS = 8
MIN_TURN_DEG = 15.0  # a turn below this is left to the smooth fit
GATE_DEG = 7.0  # two faces MIN_TURN_DEG apart put a normal at least half of it off the mean
MAX_TURN_DEG = 165.0  # faces this close to back to back: flipped normals, not an edge
MIN_Z = 6.0
LOOSE_SCATTER = 8.0  # without the smooth field's test, the turn is 8 x a contact's scatter
MIN_APART = 0.8  # share of contacts on their face's side of the edge
MIN_DEPTH = 0.05  # each face's contacts span this share of the patch across the edge
HALF_FLOOR_DEG = 1e-6  # noise-free faces: the interval holds the round-off
MAX_LEFT_OUT = 2  # the normal screen's most (docs/ep2.md)
FLAT_SHARE = 0.25  # a face's own turn, carried to the other face, explains under this share
FLAT_Z = 2.0
TIGHT = 0.1  # a face's normals scatter by under this share of the step (rms)
MIN_SPREAD = 0.05  # rms, of the patch: a side thinner than this across is one line
MIN_ACROSS = 0.02  # rms, of the patch: a line running across the edge by less sees nothing
CONST_CHI2 = {1: 13.82, 2: 18.47}  # by directions a side spans (2 dof each): 99.9 %
NOISE_FLOOR = 1e-6  # rad: noise-free normals are constant to their round-off


@dataclass
class Edge:
    """An edge between two faces; lengths in the input unit, directions unit vectors."""

    kind: str  # "ridge" or "valley"
    point: np.ndarray  # (3,) on the edge, nearest the contacts' middle
    direction: np.ndarray  # (3,)
    dihedral_deg: float
    dihedral_interval: tuple  # 95 % (deg)
    sides: tuple  # (rows of face 1, rows of face 2), indices into the patch's rows
    normals: tuple  # each face's mean normal
    ambiguous: bool = False  # a bent surface fits the contacts as well (``check_answer``)
    direction_err_deg: float = 0.0  # the direction's 95 % half-angle (``direction_half``)

    def describe(self, unit=""):
        p = ", ".join(f"{v:.4g}" for v in self.point)
        d = ", ".join(f"{v:.3f}" for v in self.direction)
        lo, hi = self.dihedral_interval
        u = f" {unit}" if unit else ""
        return (
            f"the patch straddles an edge (a {self.kind}) at ({p}){u} along ({d})"
            f" +- {self.direction_err_deg:.1f} deg, dihedral"
            f" {self.dihedral_deg:.1f} deg (95 %: {lo:.1f}-{hi:.1f} deg), faces of"
            f" {len(self.sides[0])} and {len(self.sides[1])} contacts: fit each face alone"
            + ("; or one smooth surface curving between these two tangent planes: this layout"
               " cannot tell an edge from a smooth curve: sweep across it" if self.ambiguous
               else "")
        )  # fmt: skip


class EdgeError(DataError):
    """The patch straddles an edge; ``edge`` holds it."""

    def __init__(self, edge):
        self.edge = edge
        super().__init__(edge.describe())


def _unit(v):
    return v / np.linalg.norm(v)


def _best_cut(x, g):
    """(order, k, rss): the cut of the rows sorted by x into [:k], [k:] whose two means
    leave the least squared residual of g (n, d)."""
    order = np.argsort(x)
    gs = g[order]
    n = len(x)
    c1 = np.cumsum(gs, axis=0)
    c2 = np.cumsum(np.sum(gs**2, axis=1))
    k = np.arange(1, n)
    left = c2[:-1] - np.sum(c1[:-1] ** 2, axis=1) / k
    right = (c2[-1] - c2[:-1]) - np.sum((c1[-1] - c1[:-1]) ** 2, axis=1) / (n - k)
    rss = left + right
    ok = (k >= MIN_SIDE) & (n - k >= MIN_SIDE)
    if not ok.any():
        return order, None, np.inf
    rss = np.where(ok, rss, np.inf)
    j = int(np.argmin(rss))
    return order, int(k[j]), float(rss[j])


def _smooth_rss(pts, g, T):
    xy = pts @ T
    xy = (xy - xy.mean(axis=0)) / max(np.ptp(xy), 1e-300)
    x, y = xy.T
    A = np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])
    coef, *_ = np.linalg.lstsq(A, g, rcond=None)
    return float(np.sum((g - A @ coef) ** 2))


def find(points, normals, noise_normal=None, strict=True):
    """The ``Edge`` the contacts straddle, or None (module docstring).  points (n, 3),
    normals (n, 3) unit; ``noise_normal`` the stated normal sigma (rad), if any.  With
    ``strict`` False the step need not beat the smooth field, nor each face span the patch:
    for a patch whose fit says ``plane`` while its normals turn (``check_answer``)."""
    pts, nrm = np.asarray(points, float), np.asarray(normals, float)
    n = len(pts)
    if n < MIN_POINTS:
        return None
    total = nrm.sum(axis=0)
    if np.min(nrm @ total) > np.cos(np.radians(GATE_DEG)) * np.linalg.norm(total):
        return None  # every normal within GATE_DEG of the mean: no turn of MIN_TURN_DEG
    T = _basis(_unit(total) if np.linalg.norm(total) > 1e-9 else nrm[0])
    a = np.linalg.eigh(np.cov(nrm.T))[1][:, -1]  # the normals vary most along a
    order, k, rss_step = _best_cut(nrm @ a, nrm)
    if k is None:
        return None
    sides = (np.sort(order[:k]), np.sort(order[k:]))
    x = pts @ a
    if strict and not flat_faces(pts, nrm, sides, T, noise_normal):
        if rss_step > STEP_RATIO * _smooth_rss(pts, nrm, T):
            return None
        if min(np.ptp(x[s]) for s in sides) < MIN_DEPTH * np.ptp(x):
            return None  # a face seen along one line: as much a strongly bent curve
    n1, n2 = (_unit(nrm[s].mean(axis=0)) for s in sides)
    turn = float(np.degrees(np.arccos(np.clip(n1 @ n2, -1.0, 1.0))))
    if not MIN_TURN_DEG <= turn <= MAX_TURN_DEG:
        return None
    dof = 2 * n - 4
    s2 = max(rss_step, 0.0) / dof  # (a cumulative sum's round-off can go below 0)
    if noise_normal is not None:
        s2 = max(s2, noise_normal**2)
    se = np.degrees(np.sqrt(s2 * (1 / k + 1 / (n - k))))
    if turn < MIN_Z * se or not strict and turn < LOOSE_SCATTER * np.degrees(np.sqrt(s2)):
        return None  # (loose: each face's normals must scatter as noise does, not as lines)
    edge = _edge(pts, sides, n1, n2, turn, max(float(t975(dof)) * se, HALF_FLOOR_DEG))
    edge.direction_err_deg = direction_half(nrm, sides, edge.direction, turn, noise_normal)
    across = (pts - edge.point) @ (n2 - n1)
    eps = 1e-9 * np.ptp(pts)  # a contact on the edge itself lies on both faces
    a0, a1 = across[sides[0]], across[sides[1]]
    apart = max(  # a ridge's faces lie one way of n2 - n1, a valley's the other
        np.mean(np.concatenate([a0 <= eps, a1 >= -eps])),
        np.mean(np.concatenate([a0 >= -eps, a1 <= eps])),
    )
    return edge if apart >= MIN_APART else None  # else the faces interleave: no edge


def flat_faces(pts, nrm, sides, T, noise_normal=None):
    """Whether each side's normals stay constant: each side's scatter about its mean is
    under ``TIGHT`` of the step between the means (rms), and on every side seen across the
    edge (at least one) the normals' gradient along each direction the side spans (rms
    spread over ``MIN_SPREAD`` of the patch; in the tangent plane ``T`` (3, 2)), with
    ``FLAT_Z`` standard errors, carried from one side's middle to the other's, explains
    under ``FLAT_SHARE`` of the step.  A bent surface's normals turn within each side as
    between them.  A side along one line sees across the edge as far as it runs across."""
    xy = pts @ T
    means = _tight(nrm, sides)
    if means is None:
        return False
    step = float(np.linalg.norm(means[1] - means[0]))
    along = T.T @ np.cross(*means)  # the edge, in the tangent plane
    if not any(along):
        return False
    across = np.array([-along[1], along[0]]) / np.linalg.norm(along)
    mids = [xy[s].mean(axis=0) for s in sides]
    span = np.ptp(xy, axis=0).max()
    dist = abs(float((mids[1] - mids[0]) @ across))
    if dist < MIN_DEPTH * span:
        return False
    fits = [_gradient(xy[s] - mid, nrm[s] - m, across, (MIN_SPREAD * span) ** 2)
            for s, mid, m in zip(sides, mids, means)]  # fmt: skip
    s2 = sum(f[0] for f in fits) / max(2 * (len(nrm) - 6), 1)  # (two components carry noise)
    if noise_normal is not None:
        s2 = max(s2, noise_normal**2)
    limit = FLAT_SHARE * step / dist
    told = [(g, FLAT_Z * np.sqrt(s2 / w)) for _, g, w in fits if g is not None]
    told = [np.max(g + z) for g, z in told if np.max(z) < limit]  # sides that can tell
    return bool(told) and max(told) <= limit


def _rms(m):
    return float(np.sqrt(np.mean(np.sum(m**2, axis=1))))


def _tight(nrm, sides):
    """Each side's mean normal, or None where a side's normals scatter over ``TIGHT`` of
    the step between the means (rms): outliers, not a face."""
    means = [nrm[s].mean(axis=0) for s in sides]
    step = float(np.linalg.norm(means[1] - means[0]))
    return None if max(_rms(nrm[s] - m) for s, m in zip(sides, means)) > TIGHT * step else means


def _gradient(u, m, across, wide):
    """(rss, |gradient| across the edge per spanned direction, its sum of squares) of one
    side's normals m (k, 3) over its coordinates u (k, 2) about their means; (rss, None,
    None) where the side is not seen across the edge (its rms spread across it under
    ``MIN_ACROSS`` of the patch, ``wide`` being ``MIN_SPREAD``'s square), or has fewer
    than 4 contacts."""
    w, V = np.linalg.eigh(u.T @ u)
    spans = w > len(u) * wide
    cos = 1.0 if spans[0] else abs(float(V[:, 1] @ across))
    seen = w[1] * cos**2 > len(u) * (MIN_ACROSS / MIN_SPREAD) ** 2 * wide
    if len(u) < 4 or not spans[1] or not seen:
        return float(np.sum(m**2)), None, None  # (not seen across the edge)
    c = u @ V[:, spans]
    g, *_ = np.linalg.lstsq(c, m, rcond=None)  # (spans, 3): the normals' gradient
    return float(np.sum((m - c @ g) ** 2)), np.linalg.norm(g, axis=1) / cos, w[spans] * cos**2


def constant_faces(pts, nrm, sides, noise_normal=None):
    """Whether each side's normals are constant within the noise: they scatter under
    ``TIGHT`` of the step, and their gradient over the directions the side spans (rms spread
    over ``MIN_SPREAD`` of the patch: a line spans one; a cluster none, and is no face) is
    under chi-square's 99.9 % (``CONST_CHI2``).  Two lines along an edge, or along a
    cylinder, pass: either surface fits them."""
    means = _tight(nrm, sides)
    if means is None:
        return False
    xy = pts @ _basis(_unit(nrm.sum(axis=0)))
    wide, stats, rss, dof = (MIN_SPREAD * np.ptp(xy, axis=0).max()) ** 2, [], 0.0, 2 * len(pts)
    for s, m in zip(sides, means):
        u = xy[s] - xy[s].mean(axis=0)
        w, V = np.linalg.eigh(u.T @ u)
        c = u @ V[:, w > len(u) * wide]  # (orthogonal columns: each g row's variance s2 / c.c)
        if not c.shape[1]:
            return False
        g = np.linalg.lstsq(c, nrm[s] - m, rcond=None)[0]
        rss, dof = rss + float(np.sum((nrm[s] - m - c @ g) ** 2)), dof - 2 - 2 * c.shape[1]
        stats.append((float(np.sum(g**2 * np.sum(c**2, axis=0)[:, None])), c.shape[1]))
    s2 = max(rss / max(dof, 1), (noise_normal or 0.0) ** 2, NOISE_FLOOR**2)
    return all(chi2 <= CONST_CHI2[k] * s2 for chi2, k in stats)  # fmt: skip


def direction_half(nrm, sides, direction, turn, noise_normal=None):
    """The 95 % half-angle (deg) of the edge's direction n1 x n2 (delta method): each face's
    mean normal errs along the edge by s / sqrt(k) (s the normals' scatter along it about
    their face's mean, pooled, n - 2 dof, at least ``noise_normal``; k the face's count),
    which turns n1 x n2 by that over sin(turn) about n2 (face 1) or n1 (face 2): a 2-D
    error across the edge of covariance s^2 / sin^2(turn) (u1 u1' / k1 + u2 u2' / k2),
    u1 . u2 = -cos(turn).  Its norm's 95 % quantile from ``_DRAWS`` (fixed), Student t's
    widening for the dof; at least ``HALF_FLOOR_DEG``."""
    ks = [len(s) for s in sides]
    along = [(nrm[s] - nrm[s].mean(axis=0)) @ direction for s in sides]
    s2 = sum(float(a @ a) for a in along) / max(sum(ks) - 2, 1)
    if noise_normal is not None:
        s2 = max(s2, noise_normal**2)
    t = np.radians(turn)
    a, b = 1 / ks[0], 1 / ks[1]  # eigenvalues of [[a, -a c], [-b c, b]], c = cos(turn)
    mid, det = (a + b) / 2, a * b * np.sin(t) ** 2
    root = np.sqrt(max(mid**2 - det, 0.0))
    lam = np.array([mid + root, max(mid - root, 0.0)]) * s2 / np.sin(t) ** 2
    q = float(np.quantile(np.sqrt(_DRAWS @ lam), 0.95))
    half = np.degrees(q) * float(t975(sum(ks) - 2)) / Z975
    return float(max(half, HALF_FLOOR_DEG))


_DRAWS = np.random.default_rng(0).standard_normal((4000, 2)) ** 2  # (z1^2, z2^2), fixed


def _edge(pts, sides, n1, n2, turn, half):
    c1, c2 = (pts[s].mean(axis=0) for s in sides)
    direction = _unit(np.cross(n1, n2))
    A = np.stack([n1, n2])
    mid = pts.mean(axis=0)
    b = np.array([n1 @ c1, n2 @ c2])
    point = mid + A.T @ np.linalg.solve(A @ A.T, b - A @ mid)
    kind = "ridge" if (c1 - c2) @ (n2 - n1) < 0 else "valley"
    dihedral = 180.0 - turn
    lo, hi = max(dihedral - half, 0.0), min(dihedral + half, 180.0)
    return Edge(kind, point, direction, dihedral, (lo, hi), sides, (n1, n2))


def check(prep):
    """Raise ``EdgeError`` for a prepared patch (``patch_input.Prepared``) that straddles an
    edge, ``DataError`` where over ``MAX_LEFT_OUT`` normals disagree with the rest and no
    edge explains them.  The edge's point is in the input frame."""
    edge = find(prep.points, prep.normals, prep.jet.noise_normal)
    if edge is not None:
        edge.point = edge.point + prep.middle
        raise EdgeError(edge)
    _ambiguous(prep, constant=True)  # two groups of constant normals: an edge or a curve
    nrm, limit = prep.normals, prep.jet.max_normal_angle
    cosmax = np.cos(np.radians(limit))
    seed = nrm[int(np.argmax(nrm @ nrm.sum(axis=0)))]  # the medoid, as the screen's
    mean = _unit(nrm[nrm @ seed > cosmax].sum(axis=0))
    cos = nrm @ mean
    far = np.flatnonzero(cos <= cosmax)
    if len(far) > MAX_LEFT_OUT:
        _ambiguous(prep)  # two groups of normals: an edge along the lines, said as such
        names = prep.names
        rows = ", ".join(names[i] if names is not None else f"contact {i}" for i in far[:4])
        more = f" and {len(far) - 4} more" if len(far) > 4 else ""
        deg = np.degrees(np.arccos(np.clip(cos[far], -1.0, 1.0)))
        raise DataError(
            f"a bad patch: {len(far)} normals ({rows}{more}) are {deg.min():.0f}-{deg.max():.0f}"
            f" deg from their neighbours' (limit {limit:g} deg, --max-normal-angle; at most"
            f" {MAX_LEFT_OUT} are left out) and no edge explains them: flipped normals, or a"
            " surface bent beyond one fit (take a smaller patch)"
        )


def check_answer(prep, out):
    """Raise ``EdgeError`` (the edge as one reading) where the fit says ``plane``, or
    "positions and normals disagree" (``out`` a ``DataError``), but the normals fall in two
    groups (``find``, loose).  Any other answer across a curvature jump: ``uncertain``."""
    if isinstance(out, DataError):
        if not str(out).startswith("positions and normals disagree"):
            return
    elif out.centre.shape != "plane":
        curvature_jump.check(prep, out)
        return
    _ambiguous(prep)


def _ambiguous(prep, constant=False):
    """Raise the ``EdgeError`` of the edge the contacts may straddle (``find``, loose), as
    one reading of two; with ``constant``, only where ``constant_faces``."""
    pts, nrm, noise = prep.points, prep.normals, prep.jet.noise_normal
    edge = find(pts, nrm, noise, strict=False)
    if edge is not None and (not constant or constant_faces(pts, nrm, edge.sides, noise)):
        edge.point = edge.point + prep.middle
        edge.ambiguous = True
        raise EdgeError(edge)
