"""A region map of S over one object: ``map_contacts`` (thesis §6.2.2, §6.2.4, fig. 50).

For a long sweep, or many patches over one object, the contacts are segmented into smooth
regions separated by edges and curvature jumps, and each region is described:

1. **Neighbours.**  Each contact is linked to its ``neighbours`` nearest contacts.
2. **Edges.**  A link whose two normals differ by more than ``edge_angle`` (deg) crosses an
   edge and is cut.
3. **Local shape.**  Each contact's neighbourhood (itself and its neighbours) is fitted by
   ``analyze_patches``: a local S, k1, k2 and label (neighbourhoods that straddle an edge
   or are refused have none).
4. **Curvature jumps.**  A contact whose neighbourhood is ``uncertain`` or not fitted (it
   straddles a join) takes its labelled neighbours' most common label; then a link between
   two contacts whose labels differ (a plane beside a cylinder, a cylinder beside a sphere)
   is cut too.
5. **Regions** are the connected contacts; regions under ``min_region`` contacts, or under
   twice that with under half their local fits confident (a strip along a join), join
   the neighbouring region they share most links with.
6. **Each region** is described by its contacts' local fits: the median of S, k1 and k2,
   with the 2.5-97.5 % range of the local values, widened to the median local 95 %
   interval, as the interval (a region is as curved as its parts, and as known as they
   are; one 2-jet cannot follow a half cylinder), and a label voted by them
   (``_label``: an ``uncertain`` fit votes its label shares; disagreement stays
   ``uncertain``).
7. **Edges between regions**: the regions that share links are adjacent; their boundary's
   contacts are fitted by ``edges.find`` for a crease (point, direction with its 95 %
   half-angle, dihedral angle with its interval), else the boundary is a curvature jump
   (dihedral 180 deg), placed where the normals' turn across it is best a hinge (constant
   on one side, growing on the other): its direction the total-least-squares line through
   the hinges of sections across it, with a 95 % half-angle; its point the hinge across
   it from the crossing links' middle.
"""

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import edges, geometry, patch_input
from tactile.ep2.batch import analyze_patches
from tactile.errors import DataError, InputError

NEIGHBOURS = 12
EDGE_ANGLE_DEG = 20.0
MIN_REGION = 8
JUMP_REACH = 2.5  # a jump is placed from the contacts within this many link lengths
JUMP_PASSES = 2  # fits of a jump's direction through its sections' hinge points
AGREE = 0.75  # the share of a region's confident local labels its label must hold
CHUNK = 512  # rows of the distance matrix at a time


@dataclass
class Region:
    id: int
    contacts: list  # row indices
    shape: str
    S: float | None
    k1: float
    k2: float
    S_interval: tuple | None
    k1_interval: tuple
    k2_interval: tuple
    direction1: list | None

    def to_dict(self):
        out = {k: getattr(self, k) for k in ("id", "shape", "S", "k1", "k2")}
        out.update(S_interval=self.S_interval, k1_interval=self.k1_interval,
                   k2_interval=self.k2_interval, direction1=self.direction1,
                   n_points=len(self.contacts), contacts=self.contacts)  # fmt: skip
        return out


@dataclass
class RegionEdge:
    regions: tuple  # (id, id)
    kind: str  # ridge, valley or curvature jump
    point: list
    direction: list | None
    dihedral_deg: float | None
    dihedral_interval: tuple | None
    direction_err_deg: float | None = None  # the direction's 95 % half-angle (deg)

    def to_dict(self):
        return dict(self.__dict__, regions=list(self.regions))


@dataclass
class RegionMap:
    regions: list
    edges: list
    adjacency: dict = field(default_factory=dict)  # region id -> sorted ids beside it

    def to_dict(self):
        return {
            "regions": [r.to_dict() for r in self.regions],
            "edges": [e.to_dict() for e in self.edges],
            "adjacency": {str(k): v for k, v in self.adjacency.items()},
        }


def neighbours(points, k):
    """(n, k) indices of each contact's k nearest others."""
    n = len(points)
    k = min(k, n - 1)
    out = np.empty((n, k), int)
    sq = np.sum(points**2, axis=1)
    for lo in range(0, n, CHUNK):
        d = sq[lo : lo + CHUNK, None] + sq[None] - 2 * points[lo : lo + CHUNK] @ points.T
        d[np.arange(len(d)), np.arange(lo, lo + len(d))] = np.inf
        out[lo : lo + CHUNK] = np.argpartition(d, k - 1, axis=1)[:, :k]
    return out


def _components(n, links):
    """Labels 0.. of the connected components of n nodes under (m, 2) links."""
    parent = np.arange(n)

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in links:
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([root(i) for i in range(n)])
    return np.unique(roots, return_inverse=True)[1]


def _local(points, normals, nb, kw):
    patches = [
        {"points": points[np.r_[i, row]], "normals": normals[np.r_[i, row]]}
        for i, row in enumerate(nb)
    ]
    return analyze_patches(patches, **kw)


def map_contacts(points, normals, finger=None, *, neighbours_k=NEIGHBOURS,
                 edge_angle=EDGE_ANGLE_DEG, min_region=MIN_REGION, **kw):  # fmt: skip
    """``RegionMap`` of the contacts (module docstring).  ``kw`` are ``analyze_patch``'s
    options for the local fits (the noise, stated)."""
    pts = np.asarray(points, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < min_region:
        raise InputError(f"a map needs (n, 3) points, n >= {min_region}; got {pts.shape}")
    nrm = geometry.unit_normals(np.asarray(normals, float))
    nb = neighbours(pts, neighbours_k)
    links = np.column_stack([np.repeat(np.arange(len(pts)), nb.shape[1]), nb.ravel()])
    crease = np.sum(nrm[links[:, 0]] * nrm[links[:, 1]], axis=1) < np.cos(np.radians(edge_angle))
    local = _local(pts, nrm, nb, kw)
    label = _settled([None if isinstance(r, Exception) else r.shape for r in local], nb)
    jump = np.array([label[a] is not None and label[b] is not None and label[a] != label[b]
                     for a, b in links])  # fmt: skip
    region = _components(len(pts), links[~crease & ~jump])
    sure = np.array([not isinstance(r, Exception) and r.shape != "uncertain" for r in local])
    region = _merge_small(region, links, min_region, sure)
    return _describe(pts, nrm, region, links, local, kw)


def _settled(labels, nb, passes=4):
    """Labels with ``uncertain`` and unfitted neighbourhoods (they straddle a join) given
    the most common label of their labelled neighbours, a few passes over."""
    label = np.array([None if v == "uncertain" else v for v in labels], object)
    for _ in range(passes):
        todo = [i for i in range(len(label)) if label[i] is None]
        if not todo:
            break
        new = label.copy()
        for i in todo:
            votes = Counter(v for v in label[nb[i]] if v is not None)
            new[i] = votes.most_common(1)[0][0] if votes else None
        label = new
    return label


def _merge_small(region, links, min_region, sure):
    """Regions under ``min_region`` contacts, or under twice that with under half their
    local fits confident (a strip along a join, labelled by a stray local label), joined
    to the neighbouring region they share most links with, one at a time."""
    while True:
        sizes = np.bincount(region)
        held = np.bincount(region, weights=sure, minlength=len(sizes))
        small = [r for r in np.flatnonzero(sizes) if sizes[r] < min_region
                 or (sizes[r] < 2 * min_region and held[r] < sizes[r] / 2)]  # fmt: skip
        if not small or len(np.flatnonzero(sizes)) == 1:
            return np.unique(region, return_inverse=True)[1]
        r = small[0]
        a, b = region[links[:, 0]], region[links[:, 1]]
        other = Counter(b[(a == r) & (b != r)].tolist()) + Counter(a[(b == r) & (a != r)].tolist())
        if not other:
            return np.unique(region, return_inverse=True)[1]
        region[region == r] = other.most_common(1)[0][0]


def _describe(pts, nrm, region, links, local, kw):
    regions = [_region(r, np.flatnonzero(region == r), local) for r in range(region.max() + 1)]
    a, b = region[links[:, 0]], region[links[:, 1]]
    pairs = sorted({(int(min(x, y)), int(max(x, y))) for x, y in zip(a, b) if x != y})
    found = [_edge(pts, nrm, region, links, p, kw) for p in pairs]
    adjacency = {r.id: sorted({y for x, y in pairs if x == r.id} | {x for x, y in pairs
                                                                     if y == r.id})
                 for r in regions}  # fmt: skip
    return RegionMap(regions, found, adjacency)


def _quant(v, iv=None):
    """(median of ``v``, interval): the 2.5-97.5 % range of the local values, widened to the
    median local 95 % interval (``iv``, None where a part has none), so the interval holds
    both the region's spread and what a typical part knows of it."""
    v = np.asarray(v, float)
    lo, hi = np.quantile(v, 0.025), np.quantile(v, 0.975)
    known = [i for i in (iv or ()) if i is not None]
    if known:
        lo = min(lo, np.median([a for a, _ in known]))
        hi = max(hi, np.median([b for _, b in known]))
    return float(np.median(v)), (float(lo), float(hi))


def _region(rid, rows, local):
    fits = [local[i] for i in rows if not isinstance(local[i], Exception)]
    if not fits:
        raise DataError(f"region {rid} ({len(rows)} contacts): no neighbourhood in it is fitted")
    k1, k1_iv = _quant([f.k1 for f in fits], [f.k1_interval for f in fits])
    k2, k2_iv = _quant([f.k2 for f in fits], [f.k2_interval for f in fits])
    s_fits = [f for f in fits if f.S is not None]
    S, S_iv = (
        _quant([f.S for f in s_fits], [f.S_interval for f in s_fits]) if s_fits else (None, None)
    )
    shape = _label(fits, S)
    S, S_iv = (None, None) if shape == "plane" else (S, S_iv)
    mid = int(np.argmin([abs(f.k1 - k1) + abs(f.k2 - k2) for f in fits]))
    d1 = fits[mid].direction1
    return Region(rid, [int(i) for i in rows], shape, S, k1, k2, S_iv, k1_iv, k2_iv,
                  None if d1 is None else [float(v) for v in d1])  # fmt: skip


def _label(fits, S):
    """The region's label: its confident local labels, each one vote, plus the votes of
    its ``uncertain`` local fits (their top labels' shares), summed; ``uncertain`` where
    the confident labels disagree (the top one under ``AGREE`` of them), the sum's top is
    not theirs, or the median S lies outside that label's band."""
    confident = Counter(f.shape for f in fits if f.shape != "uncertain")
    if not confident:
        return "uncertain"
    top, n = confident.most_common(1)[0]
    votes = Counter(confident)
    for f in fits:
        if f.shape == "uncertain":
            votes.update(f.votes)
    if n < AGREE * confident.total() or votes.most_common(1)[0][0] != top:
        return "uncertain"
    if top != "plane" and (S is None or geometry.s_region_map(S) != top):
        return "uncertain"
    return top


def _edge(pts, nrm, region, links, pair, kw):
    a, b = region[links[:, 0]], region[links[:, 1]]
    cross = ((a == pair[0]) & (b == pair[1])) | ((a == pair[1]) & (b == pair[0]))
    rows = np.unique(links[cross].ravel())
    near = np.unique(np.concatenate([rows, links[np.isin(links[:, 0], rows), 1]]))
    near = near[np.isin(region[near], pair)]
    mid = pts[near].mean(axis=0)
    e = edges.find(pts[near] - mid, nrm[near], patch_input.keywords(**kw).jet.noise_normal)
    if e is None:
        return _jump(pair, pts, nrm, links[cross])
    return RegionEdge(pair, e.kind, [float(v) for v in e.point + mid],
                      [float(v) for v in e.direction], float(e.dihedral_deg),
                      tuple(float(v) for v in e.dihedral_interval),
                      float(e.direction_err_deg))  # fmt: skip


def _jump(pair, pts, nrm, crossing):
    """A curvature jump: its direction the line through the hinge points of sections across
    it (``_hinge_line``; at first the crossing links' midpoints' principal axis), with the
    direction's 95 % half-angle; its point the midpoint nearest the midpoints' mean, moved
    across the line by ``_hinge``."""
    mids = 0.5 * (pts[crossing[:, 0]] + pts[crossing[:, 1]])
    centre = mids.mean(axis=0)
    point = mids[int(np.argmin(np.sum((mids - centre) ** 2, axis=1)))]
    if len(mids) < 2 or not np.ptp(mids, axis=0).max() > 0:
        return RegionEdge(pair, "curvature jump", [float(v) for v in point], None, 180.0, None)
    d, err = np.linalg.svd(mids - centre)[2][0], None
    spacing = float(np.median(np.linalg.norm(pts[crossing[:, 0]] - pts[crossing[:, 1]], axis=1)))
    for _ in range(JUMP_PASSES):
        line = _hinge_line(pts, nrm, mids, point, d, spacing)
        if line is None:
            break
        d, err = line
    moved = _hinge(pts, nrm, point, d, spacing)  # (a point on it: the line may be an arc)
    point = point if moved is None else moved[0]
    return RegionEdge(pair, "curvature jump", [float(v) for v in point], [float(v) for v in d],
                      180.0, None, err)  # fmt: skip


def _hinge_line(pts, nrm, mids, point, d, spacing):
    """(direction, its 95 % half-angle in deg) of the total-least-squares line through the
    hinge points of sections across the line (``point``, ``d``), one every link length
    along the crossing links' midpoints and each a link length either side, in the plane
    across the contacts' mean normal (an arc's bow, along the normal, drops out); None
    under 3 hinge points.  The half-angle takes each hinge point's offset from the line
    as its scatter about it plus a cut's rounding (a hinge falls between two contacts)."""
    along = (pts - point) @ d
    ends = (mids - point) @ d
    hinges, gaps = [], []
    for c in np.arange(ends.min(), ends.max() + spacing / 2, spacing):
        sel = np.abs(along - c) <= spacing
        h = _hinge(pts[sel], nrm[sel], point + c * d, d, spacing)
        if h is not None:
            hinges.append(h[0])
            gaps.append(h[1])
    if len(hinges) < 3:
        return None
    m = geometry.unit_normals(nrm[np.abs(along - ends.mean()) <= np.ptp(ends) / 2 + spacing]
                              .sum(axis=0)[None])[0]  # fmt: skip
    flat = np.asarray(hinges) - np.mean(hinges, axis=0)
    flat -= np.outer(flat @ m, m)
    _, sv, vt = np.linalg.svd(flat, full_matrices=False)
    new = vt[0] if vt[0] @ d >= 0 else -vt[0]
    # each hinge point off the line by its scatter, or by where between two contacts its
    # cut falls (uniform over a link length), whichever the points' spread does not show
    var = sv[1] ** 2 / max(len(hinges) - 2, 1) + np.mean(np.square(gaps)) / 12
    se = np.sqrt(var) / max(sv[0], 1e-300)
    return new, float(np.degrees(np.arctan(1.96 * se)))


def _hinge(pts, nrm, centre, d, spacing, reach=JUMP_REACH):
    """Where across the line (``centre``, ``d``) the normals' turn across it is best a
    hinge: constant on one side, growing linearly on the other (a plane or a cylinder's
    straight side beside a curved part), over the contacts within ``reach`` link lengths
    of the line: (the point, the gap between the two contacts its cut falls between); None
    where fewer than 3 lie on each side."""
    rel = pts - centre
    along = rel @ d
    off = rel - np.outer(along, d)
    near = np.linalg.norm(off, axis=1) <= reach * spacing
    if near.sum() < 6:
        return None
    m = nrm[near].sum(axis=0)
    across = np.cross(d, m)
    across /= max(np.linalg.norm(across), 1e-300)
    u = off[near] @ across
    y = np.arcsin(np.clip(nrm[near] @ across, -1.0, 1.0))
    order = np.argsort(u)
    u, y = u[order], y[order]
    best, where, gap = np.inf, None, None
    for k in range(3, len(u) - 2):
        cut = 0.5 * (u[k - 1] + u[k])
        for side in (1.0, -1.0):
            A = np.column_stack([np.ones_like(u), np.maximum(side * (u - cut), 0.0)])
            coef, *_ = np.linalg.lstsq(A, y, rcond=None)
            r = float(np.sum((A @ coef - y) ** 2))
            if r < best:
                best, where, gap = r, cut, u[k] - u[k - 1]
    return None if where is None else (centre + where * across, float(gap))
