"""Closed-loop exploration: the next touch placed where the patch is least known (§6.2.2-6.2.3).

The thesis's future work asks that what has been felt choose the next probe: the principal
directions to steer it (§6.2.2, "curvature flow"), the shapes still feasible to guide it
(§6.2.3, the interpretation tree).  For a fingertip that touches one point at a time
(docs/explore.md):

1. **Seed** (``SEED``) until a fit answers: the region's centre, then a circle around it; or,
   with ``lattice``, the square's 3 x 3 lattice (``LATTICE``) whatever the fit says.
2. **Fit** every contact so far with EP2 (``fit_of``): S at the patch centre, its 95 %
   interval, the label (a curved one only while its S interval stays in its band; a plane
   once both curvatures are within ``flat``).
3. **Choose** (``Explorer.plan``) on a grid in the fit's principal-direction frame the touch
   whose predicted contact leaves the narrowest S interval (a plane: k interval); a refused
   fit falls back to the point farthest from every contact.
4. **Stop** (``Explorer.done``) once the label is confident after ``MIN_TOUCHES``, or when the
   budget is spent, saying what is still unknown (``unknown``).
5. **Edges** (``edges.find``): a touch across an edge is named; the first touch's face is kept.

EP1's next roll is ``tactile.ep1.estimator.next_roll``.  Lengths: the caller's unit.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from tactile.ep2 import analyze_patch, analyze_patches, edges
from tactile.ep2.geometry import S_REGIONS
from tactile.errors import DataError, InputError

__all__ = ["MIN_TOUCHES", "Explorer", "Fit", "Region", "TouchPlan", "fit_of", "seed_points",
           "unknown"]  # fmt: skip

MIN_TOUCHES = edges.MIN_POINTS  # a label waits until an edge could be seen (8)
SEED = (90.0, 210.0, 330.0, 30.0, 150.0, 270.0)  # seed angles on the circle (deg)
SEED_RADIUS = 0.85  # of the region's half-size (a wider footprint pins the quadratic terms)
LATTICE = ((1, 1), (-1, -1), (-1, 1), (1, -1), (1, 0), (-1, 0), (0, 1), (0, -1))  # x half-size
GRID = 13  # candidates per side of the principal-direction grid (and of the space filling)
MIN_GAP = 0.15  # of the half-size: no candidate this close to a contact
STEP = 1e-4  # of the half-size: the finite difference of the fitted surface's slope
Z95, Z99, EPS = 1.959964, 2.575829, 1e-12  # two-sided 95 and 99 % normal quantiles; a tolerance
S_BANDS = {name: (lo, hi) for lo, hi, name in S_REGIONS}
DOUBT_SD = 3.5  # a normal this many sds off the fit withholds the label (``Explorer._doubt``)


@dataclass(frozen=True)
class Region:
    """Where to explore: ``centre`` (3,), ``normal`` (3,) pointing from the object toward the
    finger (the touches come along -normal), ``half`` the half-size of the square explored,
    ``standoff`` the distance a touch starts above the expected surface."""

    centre: tuple
    normal: tuple
    half: float
    standoff: float

    def axes(self):
        """(e1, e2, n): two unit vectors across the normal and the normal."""
        n = _unit(np.asarray(self.normal, float))
        ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = _unit(ref - (ref @ n) * n)
        return e1, np.cross(n, e1), n

    def local(self, points):
        """Region-frame (x, y) of world points (k, 3)."""
        e1, e2, _ = self.axes()
        d = np.asarray(points, float) - np.asarray(self.centre, float)
        return np.column_stack([d @ e1, d @ e2])


@dataclass(frozen=True)
class TouchPlan:
    """The next touch: start (3,), unit direction (3,), travel limit, where in the principal
    frame (u, v) or None for a seed, and why (one line)."""

    start: tuple
    direction: tuple
    max_travel: float
    uv: tuple | None
    why: str


@dataclass
class Fit:
    """What the contacts so far say: the ``PatchResult`` or None, the refusal's line, the
    label and its confidence as the stop rule reads them, and an edge found (``edges.Edge``)."""

    result: object = None
    refused: str | None = None
    label: str = "none"
    confidence: float = 0.0
    edge: object = None
    doubt: str | None = None  # why a label that looks confident is not given

    def row(self, touch):
        """explore.csv's row: touch, S, S_lo, S_hi, shape, confidence (None: no value)."""
        r = self.result
        lo, hi = r.S_interval if r is not None and r.S_interval else (None, None)
        return {"touch": touch, "S": r and r.S, "S_lo": lo, "S_hi": hi, "shape": self.label,
                "confidence": r and round(self.confidence, 6)}  # fmt: skip


def fit_of(points, normals, confidence=0.95, flat=None, **options):
    """``Fit`` of the contacts (k, 3) (``analyze_patch`` with ``options``): EP2's label, or the
    top S band once its share of the vote reaches ``confidence`` (EP2's own asks 0.999), else
    ``uncertain``; a curved label is withheld while its S interval, widened from 95 to 99 %
    (z 2.576 / 1.960 each side, within [-1, 1]), crosses its band's edge.
    With ``flat`` (1/length) a plane is ``plane_confidence``'s, else EP2's flatness p-value."""
    pts, nrm = np.asarray(points, float), np.asarray(normals, float)
    if len(pts) < 3:
        return Fit(refused=f"{len(pts)} contact(s): a fit needs 3 at least")
    try:
        res = analyze_patch(pts, nrm, **options)
    except edges.EdgeError as exc:
        return Fit(refused=str(exc), label="edge", edge=exc.edge)
    except (DataError, InputError) as exc:
        return Fit(refused=str(exc), label="refused")
    label, conf = res.shape, float(res.confidence)
    if flat is not None and (p := plane_confidence(res, flat)) is not None:
        if p >= confidence or label == "plane":
            return Fit(result=res, label="plane", confidence=p)
    if label == "uncertain" and res.votes:
        top = max(res.votes, key=res.votes.get)
        conf = float(res.votes[top])
        label = top if conf >= confidence else "uncertain"
    if label in S_BANDS and not _inside(res.S, res.S_interval, S_BANDS[label]):
        return Fit(result=res, label="uncertain", confidence=conf, doubt=(
            f"the S interval crosses an edge of {label}'s band {S_BANDS[label]}"))  # fmt: skip
    return Fit(result=res, label=label, confidence=conf)


def plane_confidence(res, flat):
    """The smaller over k1, k2 of P(|k| < ``flat``) (1/length), k normal about its 95 %
    interval's middle with its half-width as 1.96 sd (None: no intervals): 0.95 where the
    half-width is ``flat`` about a curvature of 0."""
    ivs = (res.k1_interval, res.k2_interval)
    if any(iv is None or None in iv for iv in ivs):
        return None
    sds = [(0.5 * (lo + hi), max(0.5 * (hi - lo) / Z95 * math.sqrt(2.0), 1e-300)) for lo, hi in ivs]
    return max(0.0, min(0.5 * (math.erf((flat - m) / sd) - math.erf((-flat - m) / sd))
                        for m, sd in sds))  # fmt: skip


def confident(fit, n, confidence=0.95, min_touches=MIN_TOUCHES, s_width=None):
    """Whether ``fit`` of ``n`` contacts ends the exploration (with ``s_width``, a curved
    label also waits until its S interval is no wider)."""
    named = fit.result is not None and fit.label not in ("uncertain", "none", "refused", "edge")
    if not (named and fit.confidence >= confidence and n >= min_touches):
        return False
    return s_width is None or fit.label == "plane" or _width(fit.result.S_interval) <= s_width


def unknown(fit, n):
    """One line: what ``n`` contacts leave unknown (for a budget spent)."""
    r = fit.result
    if r is None:
        why = fit.refused or "fewer than 3 contacts were found (the misses are named above)"
        return f"after {n} touches the curvature is not determined: {why}"
    if fit.doubt and not fit.doubt.startswith("the S interval"):
        return f"after {n} touches {fit.doubt}"
    if fit.label == "plane" or r.S is None:
        w = max(_width(r.k1_interval), _width(r.k2_interval))
        return (f"after {n} touches a plane cannot be told from a curvature under {0.5 * w:.3g}"
                f" per unit length (95 %); plane confidence {fit.confidence:.3f}")  # fmt: skip
    lo, hi = r.S_interval or (r.S, r.S)
    feasible = sorted(r.votes, key=r.votes.get, reverse=True) or [r.shape]
    shares = ", ".join(f"{k} {r.votes.get(k, 0.0):.3f}" for k in feasible)
    return (f"after {n} touches S is {r.S:.3f} in [{lo:.3f}, {hi:.3f}] (95 %, width"
            f" {hi - lo:.3f}){'; ' + fit.doubt if fit.doubt else ''}; labels still feasible:"
            f" {shares}")  # fmt: skip


def _inside(s, iv, band):
    lo, hi = (max(-1.0, s - Z99 / Z95 * (s - iv[0])), min(1.0, s + Z99 / Z95 * (iv[1] - s))
              ) if iv and None not in iv else (-2.0, 2.0)  # fmt: skip
    return band[0] - EPS <= lo <= hi <= band[1] + EPS


def seed_points(region, k, lattice=False):
    """World start points of the first ``k`` seed touches: the centre, then ``SEED``'s circle
    (or with ``lattice`` the square's corners and edge mid-points, ``LATTICE``)."""
    e1, e2, n = region.axes()
    c, h, r = np.asarray(region.centre, float), region.half, SEED_RADIUS
    ring = [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a))) for a in SEED]
    offsets = [(0.0, 0.0)] + list(LATTICE if lattice else ring)
    return [c + h * (a * e1 + b * e2) + region.standoff * n for a, b in offsets[:k]]


@dataclass
class Explorer:
    """The loop's state: contacts so far, each touch's ``Fit``; ``plan`` the next touch,
    ``add`` a contact (or a miss) and refit.  ``options`` go to ``analyze_patch``."""

    region: Region
    confidence: float = 0.95
    max_touches: int = 9
    min_touches: int = MIN_TOUCHES
    flat: float | None = None  # a plane: the curvature within +-flat (1/length), see fit_of
    s_width: float | None = None  # a curved label also waits for an S interval this narrow
    lattice: bool = False  # the first 9 touches: the square's 3 x 3 lattice, then the planner
    options: dict = field(default_factory=dict)
    points: list = field(default_factory=list)
    normals: list = field(default_factory=list)
    fits: list = field(default_factory=list)
    missed: list = field(default_factory=list)  # start points of touches that found nothing
    notes: list = field(default_factory=list)
    keep: np.ndarray | None = None  # rows on the first touch's face, once an edge is found

    @property
    def touches(self):
        return len(self.points) + len(self.missed)

    @property
    def fit(self):
        return self.fits[-1] if self.fits else Fit()

    def done(self):
        """'label' (confident), 'budget' (spent) or None (go on)."""
        least = max(self.min_touches, 1 + len(LATTICE)) if self.lattice else self.min_touches
        if confident(self.fit, self._used(), self.confidence, least, self.s_width):
            return "label"
        return "budget" if self.touches >= self.max_touches else None

    def _used(self):
        return len(self.points) if self.keep is None else int(self.keep.sum())

    def add(self, point, normal, plan=None, why=None):
        """A contact (world); returns its ``Fit``.  ``point`` None: ``plan`` missed (``why``);
        its aim (half its travel on) keeps later touches away."""
        if point is None:
            aim = self.region.centre if plan is None else np.asarray(plan.start) + 0.5 * (
                plan.max_travel * np.asarray(plan.direction))  # fmt: skip
            self.missed.append(np.asarray(aim, float))
            self.notes.append(f"touch {self.touches}: {why or 'no contact within the travel'}")
            self.fits.append(self.fit)
            return self.fit
        self.points.append(np.asarray(point, float))
        self.normals.append(_unit(np.asarray(normal, float)))
        self._edge()
        pts, nrm = np.array(self.points), np.array(self.normals)
        if self.keep is not None:
            pts, nrm = pts[self.keep], nrm[self.keep]
        fit = fit_of(pts, nrm, self.confidence, self.flat, **self.options)
        if fit.edge is not None and self.keep is None:  # (seen by the fit's check, not ``find``)
            self._split(fit.edge)
            pts, nrm = np.array(self.points)[self.keep], np.array(self.normals)[self.keep]
            fit = fit_of(pts, nrm, self.confidence, self.flat, **self.options)
        self._doubt(fit, pts, nrm)
        self.fits.append(fit)
        return fit

    def _doubt(self, fit, pts, nrm):
        """A label about to be confident is withheld while a contact's normal is over
        ``DOUBT_SD`` of the fit's normal noise off the fitted surface's: a smooth patch
        through contacts on two faces (a valley of two planes read as a concave cylinder)
        misses the normals near the edge by 4-20 of them, a smooth surface by 3.4 at most
        (the bench's objects)."""
        r = fit.result
        if not confident(fit, len(pts), self.confidence, self.min_touches):
            return
        _, fitted = on_fit(r, r.frame.to_patch(pts)[:, :2], STEP * r.scale)
        off = np.sort(np.degrees(np.arccos(np.clip(np.sum(fitted * nrm, 1), -1.0, 1.0))))
        off = off[: len(off) - sum(" left out" in w for w in r.warnings)]  # (EP2's outliers)
        if off.max() > DOUBT_SD * math.degrees(r.noise_normal or 0.0):
            fit.doubt = (f"the fit misses a normal by {off.max():.1f} deg ({DOUBT_SD:g} x its"
                         " noise at most on a smooth patch): an edge near?")  # fmt: skip
            fit.label = "uncertain"
            self.notes.append(f"touch {self.touches}: {fit.doubt} not labelled yet")

    def _edge(self):
        """Look for two faces once there are enough contacts; keep the first touch's."""
        if self.keep is not None:
            self.keep = np.append(self.keep, self._same_side(self.points[-1]))
            if not self.keep[-1]:
                self.notes.append(f"touch {self.touches}: {self._across}")
            return
        if len(self.points) < edges.MIN_POINTS:
            return
        edge = edges.find(np.array(self.points), np.array(self.normals))
        if edge is not None:
            self._split(edge)

    def _split(self, edge):
        first = 0 if 0 in edge.sides[0] else 1
        self.keep = np.zeros(len(self.points), bool)
        self.keep[edge.sides[first]] = True
        self._face = (edge.point, edge.normals[first], edge.normals[1 - first])
        self._across = f"lands across an edge: {edge.describe()}; exploring the first face"
        self.notes.append(f"touch {self.touches}: {self._across}")

    def _same_side(self, p):
        point, mine, other = self._face
        return bool((np.asarray(p) - point) @ (other - mine) <= 0.0)

    def plan(self):
        """The next ``TouchPlan``."""
        n, fit = len(self.points), self.fit
        if self.lattice and self.touches < 1 + len(LATTICE):
            start = seed_points(self.region, self.touches + 1, True)[-1]
            return self._down(start, None, f"lattice {self.touches + 1}")
        if fit.result is None and n < 1 + len(SEED) and not self.missed:
            start = seed_points(self.region, n + 1)[-1]
            return self._down(start, None, f"seed {n + 1}")
        pts = np.array(self.points + self.missed).reshape(-1, 3)
        if fit.result is None:
            return self._down(self._farthest(pts), None, "space filling (no fit yet)")
        return self._best(fit.result, pts)

    def _down(self, start, uv, why):
        d = -_unit(np.asarray(self.region.normal, float))
        return TouchPlan(tuple(start), tuple(d), 2.0 * self.region.standoff, uv, why)

    def _farthest(self, pts):
        """A start point above the grid point of the region farthest from every contact."""
        e1, e2, n = self.region.axes()
        g = np.linspace(-self.region.half, self.region.half, GRID)
        xy = np.array([(a, b) for a in g for b in g])
        have = np.vstack([self.region.local(pts), [[np.inf, np.inf]]])  # (none: any will do)
        x, y = xy[int(np.argmax(np.min(np.linalg.norm(xy[:, None] - have[None], axis=-1), 1)))]
        c = np.asarray(self.region.centre, float)
        return c + x * e1 + y * e2 + self.region.standoff * n

    def _best(self, res, pts):
        cands = candidates(res, self.region, pts)
        if not len(cands["uv"]):
            return self._down(self._farthest(pts), None, "space filling (no candidate left)")
        used, nrm = np.array(self.points), np.array(self.normals)
        if self.keep is not None:
            used, nrm = used[self.keep], nrm[self.keep]
        score, what = scores(res, used, nrm, cands, self.options)
        k = int(np.argmin(score))
        if not np.isfinite(score[k]):
            return self._down(self._farthest(pts), None, "space filling (no candidate scores)")
        n = cands["normal"][k]
        start = cands["point"][k] + self.region.standoff * n
        u, v = (float(t) for t in cands["uv"][k])
        why = f"predicted {what} {score[k]:.3g} at (u, v) = ({u:.3g}, {v:.3g})"
        return TouchPlan(tuple(start), tuple(-n), 2.0 * self.region.standoff, (u, v), why)


def candidates(res, region, pts):
    """Candidate touches on the fit's principal-direction grid within the region: dict of
    ``uv`` (k, 2) principal coordinates, ``point`` (k, 3) and ``normal`` (k, 3) on the fitted
    surface (world)."""
    frame, h = res.frame, region.half
    d1 = frame.to_patch_dirs(np.asarray(res.direction1, float))[:2]
    d1 = _unit(d1) if np.linalg.norm(d1) > 1e-12 else np.array([1.0, 0.0])
    d2 = np.array([-d1[1], d1[0]])
    g = np.linspace(-math.sqrt(2.0) * h, math.sqrt(2.0) * h, GRID)
    uv = np.array([(a, b) for a in g for b in g])
    centre = frame.to_patch(np.asarray(region.centre, float)[None])[0, :2]
    point, normal = on_fit(res, centre + uv[:, :1] * d1 + uv[:, 1:] * d2, STEP * h)
    inside = np.all(np.abs(region.local(point)) <= h * (1 + 1e-9), axis=1)
    inside &= np.all(np.isfinite(point), axis=1) & np.all(np.isfinite(normal), axis=1)
    if len(pts):  # (across the region: a missed touch's start counts as a contact)
        have = region.local(pts)
        gap = np.min(np.linalg.norm(region.local(point)[:, None] - have[None], axis=-1), axis=1)
        inside &= gap > MIN_GAP * h
    return {"uv": uv[inside], "point": point[inside], "normal": normal[inside]}


def on_fit(res, xy, eps):
    """World points and unit normals (k, 3) of the fitted surface at patch-frame xy (k, 2)."""
    with np.errstate(all="ignore"):
        z = res.surface(xy)
        zx = (res.surface(xy + [eps, 0.0]) - res.surface(xy - [eps, 0.0])) / (2 * eps)
        zy = (res.surface(xy + [0.0, eps]) - res.surface(xy - [0.0, eps])) / (2 * eps)
        n = res.frame.to_world_dirs(np.column_stack([-zx, -zy, np.ones_like(zx)]))
        return res.frame.to_world(np.column_stack([xy, z])), n / np.linalg.norm(n, axis=1)[:, None]


def scores(res, pts, nrm, cands, options):
    """(score per candidate, what it is): the S interval's width with one more contact at
    the candidate (the fit's noise stated), or the widest k interval where the fit has no S
    (a plane); inf where the fit with it is refused."""
    opts = dict(options)
    opts["noise_pos"] = options.get("noise_pos", res.noise_pos)
    opts["noise_normal"] = options.get("noise_normal", res.noise_normal)
    patches = [(np.vstack([pts, p[None]]), np.vstack([nrm, n[None]]))
               for p, n in zip(cands["point"], cands["normal"], strict=True)]  # fmt: skip
    out = analyze_patches(patches, **opts)
    use_s = res.S_interval is not None
    score = np.full(len(out), np.inf)
    for i, r in enumerate(out):
        if isinstance(r, Exception):
            continue
        if use_s and r.S_interval is not None:
            score[i] = _width(r.S_interval)
        elif not use_s:
            score[i] = max(_width(r.k1_interval), _width(r.k2_interval))
    return score, ("S interval width" if use_s else "widest k interval (1/unit)")


def _width(iv):
    return math.inf if iv is None or None in iv else float(iv[1] - iv[0])


def _unit(v):
    return v / np.linalg.norm(v)
