"""One patch's input made ready to fit (``prepare``): options and contacts checked, exact
duplicates dropped, the contacts centred; shared by ``analyze_patch`` and ``analyze_patches``.

Malformed input raises ``InputError`` naming the contact (or CSV line) and column, or
the keyword and its CLI option.

The coordinates EP2 represents.  Both fits work in a frame scaled by the patch size L, so
the fit does not care about the length unit; the way in and out does: a centroid of
coordinates near 1e308 overflows, and so does a curvature of 1/L for L = 1e-310, or a
Gaussian curvature 1/L^2 beyond L ~ 1e+-154.  So the contacts' spread (the largest side of
their bounding box) must lie in [``MIN_SPREAD``, ``MAX_SPREAD``], which keeps every
reported length and curvature a finite float; outside it ``spread_problem`` says why,
naming the row that sets the spread (exit 2).  A spread of exactly 0 is left to the fit,
which refuses it (exit 3).  ``centred`` moves the middle of their box to the origin
before anything is summed.  Normals need no range: ``geometry.unit_normals`` normalises
any finite non-zero vector.
"""

import functools
from dataclasses import dataclass, fields, replace

import numpy as np

from tactile.ep2 import geometry
from tactile.errors import DataError, InputError

METHODS = ("jet", "spline")
BREAK_ANGLE_DEG = 30.0  # consecutive normals of one finger turning more: a discontinuity
MAX_GRID = 256  # analysis grid N x N: memory grows as N^2
MAX_SEGMENTS = 64  # spline segments per direction
MAX_ROWS = 250_000  # contacts in one patch: its fit holds about 5 kB a contact (1.2 GB here)
MAX_NOISE_SPREADS = 1e6  # a position noise beyond this many spreads leaves no shape to fit
WEIGHTINGS = ("auto", "tangent", "position")
JET_ORDER = 2  # the jet order of the default (--order is for method spline)


@dataclass(frozen=True)
class JetOptions:
    """The estimator's options, which both methods read: the noise (input unit, rad; None:
    estimated), the normals' angle limits (deg), the grid of the thesis's statistics and
    whether to compute intervals."""

    noise_pos: float | None = None
    noise_normal: float | None = None
    max_normal_angle: float = geometry.MAX_NORMAL_ANGLE_DEG
    break_angle: float = BREAK_ANGLE_DEG
    grid: int = 8
    intervals: bool = True


@dataclass(frozen=True)
class SplineOptions:
    """The thesis's B-spline's own options (``method="spline"``): degree per direction
    (None: 2), segments, row weighting, a refit in the principal frame, the solver, the
    shrinkage toward the 2-jet (None: on for ``auto`` weighting)."""

    order: int | None = None
    segments: int = 1
    weighting: str = "auto"
    align: bool = False
    solver: str = "svd"
    shrink: bool | None = None


_JET = tuple(f.name for f in fields(JetOptions))
_SPLINE = tuple(f.name for f in fields(SplineOptions))


@dataclass(frozen=True)
class Request:
    """What ``analyze_patch`` is asked: the method, whether to keep the grid maps, and the
    two option sets."""

    method: str = "jet"
    maps: bool = False
    jet: JetOptions = JetOptions()
    spline: SplineOptions = SplineOptions()

    def keywords(self):
        """``analyze_patch``'s keywords that ask this again."""
        return dict(method=self.method, maps=self.maps, jet=self.jet, spline=self.spline)

    def with_noise(self, **noise):
        """This request with a patch's own ``noise_pos`` / ``noise_normal`` over the jet's."""
        return replace(self, jet=replace(self.jet, **noise)) if noise else self


def keywords(method="jet", jet=None, spline=None, maps=False, **named):
    """The ``Request`` of ``analyze_patch``'s keywords: ``jet`` and ``spline`` (or their
    defaults) with options ``named`` over them, as ``analyze_patch(points, normals,
    noise_pos=0.01)`` writes them.  ``TypeError`` for a name neither set has, as Python
    gives for an unknown keyword."""
    unknown = sorted(set(named) - set(_JET) - set(_SPLINE))
    if unknown:
        raise TypeError(f"analyze_patch() got an unexpected keyword argument {unknown[0]!r}")
    jet = replace(jet or JetOptions(), **{k: v for k, v in named.items() if k in _JET})
    spline = replace(spline or SplineOptions(), **{k: v for k, v in named.items() if k in _SPLINE})
    return Request(method, maps, jet, spline)


@dataclass
class Prepared:
    """One patch ready to fit: validated, duplicates dropped, centred (``analyze_patch``).
    ``lines``: the fitted contacts' CSV lines or None; ``names``: how messages name them
    (``row_names``); ``breaks``: its discontinuities; ``middle``: what centring took off."""

    points: np.ndarray
    normals: np.ndarray
    jet: JetOptions
    lines: list | None
    names: "RowNames | None"
    breaks: list
    dropped: int
    middle: np.ndarray


def prepare(points, normals, finger, lines, req):
    """Validation and the steps before the fit, shared by one patch and a batch (``req`` a
    ``Request``)."""
    pts, nrm = validate(points, normals, req, lines)
    check_options(pts, req.jet, req.spline)
    rows = np.arange(len(pts))
    pts, nrm, finger, lines, rows, dropped = _drop_duplicates(pts, nrm, finger, lines, rows)
    pts, middle = centred(pts)  # the frame's origin moves back in ``api.PatchResult``
    (breaks,) = find_breaks(nrm[None], [finger], req.jet.break_angle)
    check_order(req.method, req.spline.order)
    names = row_names(lines, rows if dropped else None)
    return Prepared(pts, nrm, req.jet, lines, names, breaks, dropped, middle)


def prepare_stack(unpacked, reqs):
    """``prepare`` of every patch of ``unpacked`` ((points, normals, finger, lines) each, its
    ``Request`` in ``reqs``) that passes its checks as it stands (sound options, finite,
    representable spread, non-zero normals, no duplicated rows), for each group of patches
    of one size at once; None for the others, which ``prepare`` takes one at a time (it
    refuses them, or drops their duplicates).  The same numbers either way."""
    out = [None] * len(unpacked)
    groups, sound = {}, {}
    for j, (points, normals, _, _) in enumerate(unpacked):
        own = (reqs[j].jet.noise_pos, reqs[j].jet.noise_normal)  # (all else is the chunk's)
        if own not in sound:
            sound[own] = _sound(reqs[j])
        pts, nrm = np.asarray(points, float), np.asarray(normals, float)
        if sound[own] and 0 < len(pts) <= MAX_ROWS and pts.ndim == 2 and pts.shape[1] == 3:
            if nrm.shape == pts.shape:
                groups.setdefault(len(pts), []).append((j, pts, nrm))
    for group in groups.values():
        idx = [j for j, _, _ in group]
        got = _prepare_group(group, [unpacked[j] for j in idx], [reqs[j] for j in idx])
        for k, prep in zip(idx, got, strict=True):
            out[k] = prep
    return out


def _sound(req):
    """Whether the options hold for any patch (else the one-patch path says why not)."""
    try:
        _sound_method(req.method, req.spline.weighting)
        check_options(np.zeros((1, 3)), replace(req.jet, noise_pos=None), req.spline)
        check_order(req.method, req.spline.order)
        if req.jet.noise_pos is not None and not np.isfinite(float(req.jet.noise_pos)):
            return False
    except (DataError, InputError, TypeError, ValueError):
        return False
    return True


@functools.lru_cache(maxsize=16)
def _sound_method(method, weighting):
    """``validate``'s checks of the method and weighting (all it checks of the options)."""
    validate(
        np.zeros((1, 3)),
        np.ones((1, 3)),
        Request(method, spline=SplineOptions(weighting=weighting)),
    )


def _prepare_group(group, unpacked, reqs):
    """``prepare_stack`` for patches of one size: [Prepared or None]."""
    P = np.stack([pts for _, pts, _ in group])
    N = np.stack([nrm for _, _, nrm in group])
    good = np.all(np.isfinite(P), axis=(1, 2)) & np.all(np.isfinite(N), axis=(1, 2))
    middle, half = box(P)
    h = half.max(axis=-1)
    good &= (h == 0.0) | ((MIN_SPREAD <= 2.0 * h) & (2.0 * h <= MAX_SPREAD))
    noise = np.array([np.nan if r.jet.noise_pos is None else r.jet.noise_pos for r in reqs])
    top = MAX_NOISE_SPREADS * 2.0 * np.where(good, h, 0.0)  # a wild patch: not here
    good &= np.isnan(noise) | ((noise >= 0.0) & (noise <= top))
    N, ok = geometry.unit_rows(N)
    good &= np.all(ok, axis=-1)
    good &= ~has_duplicates(P, N)
    P = P - middle[:, None, :]  # ``centred``
    out = [None] * len(group)
    live = np.flatnonzero(good).tolist()
    breaks = find_breaks(N[live], [unpacked[b][2] for b in live], reqs[0].jet.break_angle)
    for b, brk in zip(live, breaks, strict=True):
        lines = unpacked[b][3]
        out[b] = Prepared(P[b], N[b], reqs[b].jet, lines, row_names(lines), brk, 0, middle[b])
    return out


def has_duplicates(P, N):
    """(G,) whether a patch repeats a row exactly (``_drop_duplicates`` drops them).  Only a
    patch with two equal x (or a non-finite number) can: the rows of those alone are
    compared whole."""
    x = np.sort(P[..., 0], axis=-1)
    maybe = np.any(x[:, 1:] == x[:, :-1], axis=-1)
    maybe |= ~(np.all(np.isfinite(P), axis=(1, 2)) & np.all(np.isfinite(N), axis=(1, 2)))
    out = np.zeros(len(P), bool)
    if maybe.any():
        G, n, _ = P[maybe].shape
        patch = np.repeat(np.arange(G, dtype=float), n)[:, None]
        rows = np.concatenate([patch, P[maybe].reshape(-1, 3), N[maybe].reshape(-1, 3)], axis=1)
        rows = rows[np.all(np.isfinite(rows), axis=1)]
        distinct = np.unique(rows, axis=0)[:, 0].astype(int)
        out[maybe] = np.bincount(distinct, minlength=G) < n
    return out


def row_names(lines, rows=None):
    """How messages name the fitted contacts: their CSV lines, their row numbers in the input
    (where duplicates were dropped) or None (as numbered)."""
    if lines is not None:
        return RowNames("line", lines)
    return None if rows is None else RowNames("contact", [int(n) for n in rows])


class RowNames:
    """Fitted contact k's name, ``names[k]``, made only when a message asks for it (most
    patches name none)."""

    def __init__(self, word, numbers):
        self.word, self.numbers = word, numbers

    def __getitem__(self, k):
        return f"{self.word} {self.numbers[k]}"


def check_order(method, order):
    if method != "spline" and order not in (None, JET_ORDER):
        raise InputError(f"the jet order is {JET_ORDER}; --order is for method spline")


def validate(points, normals, req, lines=None):
    method, weighting = req.method, req.spline.weighting
    if method not in METHODS:
        raise InputError(f"unknown method {method!r} (choose {', '.join(METHODS)})")
    if weighting not in WEIGHTINGS:
        raise InputError(f"unknown weighting {weighting!r} (choose {', '.join(WEIGHTINGS)})")
    if method == "jet" and weighting != "auto":
        raise InputError(f"weighting {weighting!r} is the thesis's: use it with method 'spline'")
    pts = np.asarray(points, float)
    nrm = np.asarray(normals, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or nrm.shape != pts.shape:
        raise InputError(f"points and normals must both be (n, 3); got {pts.shape} and {nrm.shape}")
    if len(pts) > MAX_ROWS:
        raise InputError(too_many_rows(len(pts)))
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(nrm))):
        raise InputError("points and normals must be finite numbers")
    problem = spread_problem(pts)
    if problem is not None:
        row, axis, why = problem
        at = f"contact {row}" if lines is None else f"line {lines[row]}"
        raise InputError(f"{at}: column '{AXES[axis]}': {why}")
    return pts, geometry.unit_normals(nrm)


def too_many_rows(n):
    """Why a patch of ``n`` contacts is refused (``MAX_ROWS``)."""
    return (
        f"{n:,} contacts in one patch, over the {MAX_ROWS:,} one patch may hold (its fit "
        "takes memory in proportion): split it into patches"
    )


def check_options(pts, jet, spline):
    """Numbers the fit can use, or ``InputError`` naming the keyword and its CLI option."""
    noise_pos, noise_normal, grid = jet.noise_pos, jet.noise_normal, jet.grid
    max_angle, break_angle, segments = jet.max_normal_angle, jet.break_angle, spline.segments

    def refuse(name, rule, value):
        option = "--" + name.replace("_", "-")
        return InputError(f"{name} ({option}): must be {rule}, got {value!r}")

    top = MAX_NOISE_SPREADS * 2.0 * float(box(pts)[1].max())
    if noise_pos is not None and not 0.0 <= noise_pos <= top:
        rule = f"a number >= 0 and at most {MAX_NOISE_SPREADS:g} contact spreads ({top:.3g})"
        raise refuse("noise_pos", rule, noise_pos)
    if noise_normal is not None and not 0.0 <= noise_normal <= np.pi:
        raise refuse("noise_normal", "a number of rad in [0, pi]", noise_normal)
    if not 0.0 < max_angle <= 90.0:
        raise refuse("max_normal_angle", "a number of deg in (0, 90]", max_angle)
    if not 0.0 <= break_angle <= 180.0:
        raise refuse("break_angle", "a number of deg in [0, 180]", break_angle)
    if not 2 <= grid <= MAX_GRID:
        raise refuse("grid", f"a whole number in 2..{MAX_GRID}", grid)
    if not all(1 <= n <= MAX_SEGMENTS for n in np.atleast_1d(segments)):
        raise refuse("segments", f"a whole number in 1..{MAX_SEGMENTS}", segments)


def _drop_duplicates(pts, nrm, finger, lines, rows):
    """Rows repeated exactly (same position and normal) carry no new information: keep the
    first of each, so they cannot narrow the intervals.  Returns the count dropped last."""
    _, first = np.unique(np.column_stack([pts, nrm]), axis=0, return_index=True)
    if first.size == len(pts):
        return pts, nrm, finger, lines, rows, 0
    keep = np.sort(first)
    finger = None if finger is None else [finger[i] for i in keep]
    lines = None if lines is None else [lines[i] for i in keep]
    return pts[keep], nrm[keep], finger, lines, rows[keep], len(pts) - keep.size


# --- Discontinuities along a finger's sweep (§6.2.2, §6.2.5).
#
# A crease or edge shows as consecutive normals of one finger that differ by more than an angle.
# ``find_breaks`` lists them for a stack of patches at once (``api.split_parts`` cuts a sweep
# at them).


def find_breaks(normals, fingers, max_angle_deg=BREAK_ANGLE_DEG):
    """Per patch of a stack (``normals`` (B, n, 3), unit rows in sweep order within each
    finger; ``fingers`` one label per row per patch, or None: nothing checked), the list of
    (row, finger label, angle in deg) where a finger's normal turns more than
    ``max_angle_deg``: by label (in order of first appearance), then row.  Labels compare
    as Python values do (NaN equals nothing, -0.0 equals 0.0) and come back as given
    (``np.asarray(labels).tolist()``); a label list shorter than n labels its first rows."""
    B, n = normals.shape[:2]
    codes, values = _label_codes(fingers, n), None
    if codes is None:
        codes = np.empty((B, n), np.int64)
        values = []
        for b, f in enumerate(fingers):
            given = [] if f is None else np.asarray(f).tolist()[:n]
            seen = {}
            codes[b, : len(given)] = [seen.setdefault(v, len(seen)) for v in given]
            codes[b, len(given) :] = -1 - np.arange(n - len(given))  # unlabelled: no pair
            values.append(given)
    # a stable sort puts each label's rows together in sweep order: a pair of neighbours
    # with equal codes is a consecutive pair of one finger
    order = np.argsort(codes, axis=1, kind="stable")
    ranked = np.take_along_axis(codes, order, axis=1)
    same = ranked[:, 1:] == ranked[:, :-1]
    g, k = np.nonzero(same)
    a, b = normals[g, order[g, k]], normals[g, order[g, k + 1]]
    dots = np.einsum("ij,ij->i", a, b)
    cross = np.linalg.norm(np.cross(a, b), axis=1)
    angle = np.degrees(np.arctan2(cross, dots))
    hit = np.flatnonzero(angle > max_angle_deg)
    out = [[] for _ in range(B)]
    # each run of equal codes starts at its label's first row (a stable sort)
    cols = np.arange(n)
    start = np.maximum.accumulate(np.where(np.c_[np.ones(B, bool), ~same], cols, 0), axis=1)
    g, k = g[hit], k[hit]
    row, first = order[g, k + 1], order[g, start[g, k]]
    for h in np.lexsort((row, first, g)).tolist():
        p = int(g[h])
        label = values[p][first[h]] if values is not None else fingers[p][first[h]].item()
        out[p].append((int(row[h]), label, float(angle[hit[h]])))
    return out


def _label_codes(fingers, n):
    """(B, n) sort keys of the labels where every patch's are a NumPy array of n numbers of
    one dtype, none NaN: the labels themselves, which sort and compare as Python compares
    them (-0.0 equals 0.0); else None (``find_breaks`` numbers the labels one by one)."""
    if not fingers or not all(
        type(f) is np.ndarray and f.shape == (n,) and f.dtype == fingers[0].dtype for f in fingers
    ):
        return None
    codes = np.stack(fingers)
    if codes.dtype.kind not in "iuf" or (codes.dtype.kind == "f" and np.isnan(codes).any()):
        return None
    return codes


MIN_SPREAD = 1e-300
MAX_SPREAD = 1e300
AXES = "xyz"


def box(points):
    """(middle (..., 3), half sides (..., 3)) of the points' bounding box (of each patch of a
    stack (..., n, 3)), without overflow."""
    lo, hi = points.min(axis=-2), points.max(axis=-2)
    return 0.5 * lo + 0.5 * hi, 0.5 * hi - 0.5 * lo


def spread_problem(points):
    """None, or (row, axis index, message) when the spread is outside the range EP2 holds.

    ``row`` is the contact that sets the spread along ``axis`` (the one farthest from the
    median there), so a single wild coordinate is named.
    """
    pts = np.asarray(points, float)
    if not len(pts):
        return None
    _, half = box(pts)
    axis = int(np.argmax(half))
    h = float(half[axis])
    if h == 0.0 or MIN_SPREAD <= 2.0 * h <= MAX_SPREAD:
        return None
    col = pts[:, axis]
    med = float(np.median(col))
    row = int(np.argmax(np.abs(0.5 * col - 0.5 * med)))
    span = f"{2.0 * h:.3g}" if h < 8.9e307 else "more than 1.8e+308"
    if 2.0 * h > MAX_SPREAD:
        why = (
            f"the contacts spread over {span} along {AXES[axis]}, beyond the {MAX_SPREAD:g}"
            f" EP2 can represent ({AXES[axis]} = {col[row]:.6g} here): check that value, or"
            " use a larger length unit"
        )
    else:
        why = (
            f"the contacts spread over only {span}, under the {MIN_SPREAD:g} EP2 can"
            " represent: use a smaller length unit"
        )
    return row, axis, why


def centred(points):
    """(points - middle of their box, middle): nothing downstream sums raw coordinates."""
    pts = np.asarray(points, float)
    middle, _ = box(pts)
    return pts - middle, middle
