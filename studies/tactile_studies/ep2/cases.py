"""EP2 test cases: object x layout x noise x frame, a tuning grid and a held-out split.

A ``Case`` fixes everything about one experiment but the noise draw;
``draw(case, trial)`` gives the contacts of one trial (deterministic from the
case's ``id`` and the trial number) and the truth at the patch centre
(``truth.at_centre``).  Splits:

- ``tune_cases()``: the grid estimators MAY be tuned on (three fingers, 4 x 4
  patch, apex at the patch centre, unit 1, no tilt).
- ``holdout_cases()``: FOR FINAL EVALUATION ONLY.  Never tune on it, never look
  at its per-case numbers while designing.  Its radii, rotations and noises are
  drawn from continuous ranges (fixed seed) and share no value with the tune
  grid; so do its layouts (2-4 fingers, uneven spacing, turned sweeps, grids,
  scatter; patch sizes 2-8), units, scene tilts and apex offsets.
- ``degenerate_cases()``: data that do not determine the curvature in at least
  one direction (``degenerate`` names why) or whose normals contradict the
  positions (``inconsistent``).  The right answer there is a refusal, a null S
  or an interval that holds the truth, not a confident label.

Families (the issue's targets): planes (sloped, tilted), spheres and pits
r 4-1000, cylinders and concave cylinders r 3-200 at 0-90 deg, saddles and
general quadrics (k1 != -k2, both signs); 27 or 36 contacts; noise 0-0.03, the
same sigma on each position coordinate (base unit) and per tangent axis of each
normal (rad), as ``tactile_sim.ep2.sweep``.  Curvatures follow
``tactile_sim.ep2.objects``: positive where convex toward the finger.  Cases whose noise-free
normals stray more than ``tactile.ep2.geometry.MAX_NORMAL_ANGLE_DEG`` from their mean are
kept but flagged ``steep`` (the library's default refuses them); cases the sweep cannot reach
(off the sphere, normals beyond ``MAX_ANGLE_DEG``) are shrunk or skipped.
"""

import hashlib
from dataclasses import dataclass, replace

import numpy as np

from tactile.ep2.geometry import MAX_NORMAL_ANGLE_DEG
from tactile_sim.ep2 import layouts
from tactile_sim.ep2.objects import make
from tactile_sim.ep2.sweep import _tilt_normals
from tactile_studies.ep2 import truth

FAMILIES = ("plane", "sphere", "pit", "cylinder", "concave_cylinder", "saddle", "quadric")
MAX_ANGLE_DEG = 85.0  # noise-free normals beyond this from their mean: not generated
THESIS27 = (("length", 4.0), ("stops", 9), ("xs", (0.0, 2.0, 4.0)))  # §4.1: 9 stops x 3
THESIS36 = (("length", 4.0), ("repeats", 2), ("stops", 6), ("xs", (0.0, 2.0, 4.0)))  # §5.1
HOLDOUT_SEED = 20240611
HOLDOUT2_SEED = 20261123  # the second, final held-out draw (``split``)
HOLDOUT3_SEED = 77013  # a draw nothing had seen, normal / position noise drawn apart
HOLDOUT4_SEED = 4242  # the same recipe again, for what holdout3's worst cases led to
HOLDOUT5_SEED = 5151  # and again, for the round model's truncation found on holdout4


@dataclass(frozen=True)
class Case:
    """One experiment.  Lengths in the base unit; the data are scaled by ``unit``."""

    family: str  # one of FAMILIES
    kind: str  # objects.KINDS
    k: tuple  # (k1, k2) along the object's own axes, 1/base unit
    rotation_deg: float = 0.0  # object about z (cylinder axis from the sweep direction y)
    layout: str = "sweep"  # layouts.LAYOUTS
    params: tuple = THESIS27  # sorted (key, value) pairs for the layout
    size: float = 4.0  # nominal patch size (larger side of the layout's box)
    n: int = 27  # contacts
    noise: float = 0.0  # sigma: position (base unit) and normal (rad per tangent axis)
    normal_ratio: float = 1.0  # the normals' sigma is noise x this (holdout3 draws it)
    unit: float = 1.0  # data = base-unit geometry x unit (curvatures / unit)
    tilt_deg: float = 0.0  # whole scene about an in-plane axis ...
    tilt_axis_deg: float = 0.0  # ... at this azimuth from x
    apex: tuple = (0.0, 0.0)  # object apex from the layout's centre
    slope: tuple = (0.0, 0.0)  # planes: z = a x + b y
    normals_from: str = ""  # "" | "flat" (all (0, 0, 1)) | "flipped" (normals of -h)
    degenerate: str = ""  # why the data do not determine curvature ("" if they do)
    steep: bool = False  # normals beyond the library's default limit (expect refusals)

    @property
    def inconsistent(self):
        return bool(self.normals_from)

    @property
    def radius(self):
        kmax = max(abs(v) for v in self.k)
        return None if kmax == 0 else 1.0 / kmax

    @property
    def random_layout(self):
        return self.layout == "scatter"

    @property
    def group(self):
        """Summary row: the degenerate reason, 'inconsistent', or family (+ ' steep')."""
        if self.degenerate or self.inconsistent:
            return self.degenerate or f"inconsistent ({self.normals_from})"
        return self.family + (" steep" if self.steep else "")

    @property
    def id(self):
        p = ",".join(f"{k}={_fmt(v)}" for k, v in self.params)
        shape = f"k={_fmt(self.k)}" if self.kind == "quadric" else f"r={_fmt(self.radius or 0)}"
        parts = [
            self.family,
            *([shape] if self.radius else []),
            f"rot={_fmt(self.rotation_deg)}",
            f"{self.layout}({p})",
            f"n={self.n}",
            f"sig={_fmt(self.noise)}",
        ]
        extra = {
            "nr": (self.normal_ratio, 1.0),
            "u": (self.unit, 1.0),
            "tilt": ((self.tilt_deg, self.tilt_axis_deg), (0.0, 0.0)),
            "apex": (self.apex, (0.0, 0.0)),
            "slope": (self.slope, (0.0, 0.0)),
            "normals": (self.normals_from, ""),
            "deg": (self.degenerate, ""),
        }
        parts += [f"{k}={_fmt(v)}" for k, (v, default) in extra.items() if v != default]
        return " ".join(parts)


def _fmt(v):
    if isinstance(v, tuple | list | np.ndarray):
        return "/".join(_fmt(x) for x in v)
    return v if isinstance(v, str) else f"{v:.6g}"


def seed(case, trial):
    """Stable seed from (case.id, trial): sha256, not Python's salted ``hash``."""
    digest = hashlib.sha256(f"{case.id}#{trial}".encode()).digest()
    return int.from_bytes(digest[:8], "little")


def build(case):
    """The case's ``objects.HeightField``, apex at ``case.apex``."""
    kw = dict(rotation_deg=case.rotation_deg, centre=case.apex, slope=case.slope)
    if case.kind == "quadric":
        return make("quadric", k=case.k, **kw)
    return make(case.kind, case.radius or 1.0, **kw)


def tilt_matrix(case):
    """Rotation taking object coordinates to the measured frame (about an in-plane axis)."""
    a, t = np.radians(case.tilt_axis_deg), np.radians(case.tilt_deg)
    ca, sa, ct, st = np.cos(a), np.sin(a), np.cos(t), np.sin(t)
    rz = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]])
    return rz @ rx @ rz.T


def draw(case, trial=0):
    """One trial: dict of points (n, 3), normals (n, 3), finger (n,), the in-plane layout
    ``xy``, ``seed``, the true ``noise_pos`` (data unit) and ``noise_normal`` (rad),
    and ``truth`` at the patch centre (``truth.at_centre``, plus ``determined``)."""
    s = seed(case, trial)
    rng = np.random.default_rng(s)
    xy, finger, _, _ = layouts.place(case.layout, case.params, rng)
    pts, nrm = _contacts(case, build(case), xy)
    if case.noise > 0:
        pts = pts + case.noise * rng.standard_normal(pts.shape)
        nrm = _tilt_normals(nrm, case.noise * case.normal_ratio, rng)
    rot = tilt_matrix(case)
    pts, nrm = pts @ rot.T * case.unit, nrm @ rot.T
    true = truth.at_centre(build(case), pts, nrm, case.unit, rot)
    true["determined"] = not (case.degenerate or case.inconsistent)
    return {
        "points": pts,
        "normals": nrm,
        "finger": finger,
        "xy": xy,
        "seed": s,
        "noise_pos": case.noise * case.unit,
        "noise_normal": case.noise * case.normal_ratio,
        "truth": true,
    }


def _contacts(case, obj, xy):
    """Noise-free points and normals (object frame, base unit) at the layout's xy."""
    z, zx, zy = obj.eval(xy[:, 0], xy[:, 1])
    sign = {"": -1.0, "flipped": 1.0, "flat": 0.0}[case.normals_from]
    nrm = np.column_stack([sign * zx, sign * zy, np.ones_like(zx)])
    return np.column_stack([xy, z]), nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


def check(case):
    """(case with ``steep`` set, None) if the sweep can reach it, else (None, reason)."""
    xy, _, corners, _ = layouts.place(case.layout, case.params)
    try:
        _, nrm = _contacts(replace(case, normals_from=""), build(case), np.vstack([xy, corners]))
        truth.at_centre(build(case), *_contacts(case, build(case), xy))
    except ValueError as err:
        return None, str(err)
    mean = nrm.mean(axis=0) / np.linalg.norm(nrm.mean(axis=0))
    angle = float(np.degrees(np.arccos(np.clip(nrm @ mean, -1.0, 1.0))).max())
    if angle > MAX_ANGLE_DEG:
        return None, f"normals {angle:.1f} deg from their mean (limit {MAX_ANGLE_DEG:g})"
    return replace(case, steep=angle > MAX_NORMAL_ANGLE_DEG), None


def new(family, *, radius=None, k=None, layout="sweep", params=THESIS27, **kw):
    """A checked ``Case`` (None if unreachable); k from ``radius`` via ``objects.make``."""
    kind = family  # every family is one objects.KINDS entry
    params = tuple(sorted(dict(params).items()))
    xy, _, _, size = layouts.place(layout, params)
    n = len(xy)
    kk = tuple(k) if k is not None else make(kind, radius or 1.0).k
    case, _ = check(Case(family, kind, kk, layout=layout, params=params, size=size, n=n, **kw))
    return case


# -- the tuning grid ---------------------------------------------------------------------

TUNE_RADII = (4.0, 6.0, 10.0, 20.0, 50.0, 200.0, 1000.0)  # spheres, pits, saddles
TUNE_CYLINDER_RADII = (3.0, 4.0, 6.0, 10.0, 20.0, 50.0, 200.0)
TUNE_ROTATIONS = (0.0, 30.0, 60.0, 90.0)
TUNE_NOISES = (0.0, 0.002, 0.005, 0.01, 0.02, 0.03)
TUNE_LAYOUTS = (THESIS27, THESIS36)
TUNE_SLOPES = ((0.0, 0.0), (1.0, 1.0), (3.0, 2.0))  # §4.9.1: z = 0, x + y, 3x + 2y
TUNE_QUADRIC_RADII = (6.0, 30.0)
QUADRIC_SHAPES = ((1.0, 0.4), (1.0, -0.4), (0.4, -1.0), (-0.4, -1.0))  # k / (1/r)


def _tune_objects():
    """(family, keyword) pairs of the tuning grid's objects."""
    out = [("plane", dict(slope=s)) for s in TUNE_SLOPES]
    for fam in ("sphere", "pit"):
        out += [(fam, dict(radius=r)) for r in TUNE_RADII]
    rot = TUNE_ROTATIONS
    for fam in ("cylinder", "concave_cylinder"):
        out += [(fam, dict(radius=r, rotation_deg=a)) for r in TUNE_CYLINDER_RADII for a in rot]
    out += [("saddle", dict(radius=r, rotation_deg=a)) for r in TUNE_RADII[::2] for a in rot]
    out += [
        ("quadric", dict(k=(a / r, b / r), rotation_deg=t))
        for r in TUNE_QUADRIC_RADII
        for a, b in QUADRIC_SHAPES
        for t in rot
    ]
    return out


def tune_cases():
    """The grid estimators may be tuned on (about 1500 cases)."""
    out = []
    for fam, kw in _tune_objects():
        for params in TUNE_LAYOUTS:
            out += [new(fam, params=params, noise=s, **kw) for s in TUNE_NOISES]
    return [c for c in out if c is not None]


# -- the held-out split: FINAL EVALUATION ONLY -------------------------------------------

HOLDOUT_PER_FAMILY = 60
HOLDOUT_RADII = {
    "sphere": (4.0, 1000.0),
    "pit": (4.0, 1000.0),
    "cylinder": (3.0, 200.0),
    "concave_cylinder": (3.0, 200.0),
    "saddle": (4.0, 1000.0),
    "quadric": (4.0, 300.0),
}
HOLDOUT_LAYOUTS = ("two_fingers", "four_fingers", "uneven", "twelve_stops", "grid", "scatter")


def holdout_cases(per_family=HOLDOUT_PER_FAMILY, seed=HOLDOUT_SEED, ratios=False):
    """Held-out cases, drawn with a fixed seed: FOR FINAL EVALUATION ONLY (module doc).
    ``ratios``: also draw the normals' sigma over the positions' (log-uniform 1/100..100,
    ``normal_ratio``), where the earlier draws tied them (holdout3)."""
    rng = np.random.default_rng(seed)
    out = [_holdout_one(fam, rng, ratios) for fam in FAMILIES for _ in range(per_family)]
    return [c for c in out if c is not None]


def _r4(x):
    """Round to 4 significant digits, so the id states the value exactly."""
    return float(f"{x:.4g}")


def _off(x, taken):
    """x nudged off the tune grid's values (continuous draws meet them only by rounding)."""
    return _r4(x * 1.01 + 0.01) if any(np.isclose(x, t) for t in taken) else x


def _holdout_one(fam, rng, ratios=False):
    """One held-out case: draw everything once, then shrink apex and patch until reachable."""
    kw = _holdout_object(fam, rng)
    if ratios:
        kw["normal_ratio"] = _r4(10 ** rng.uniform(-2, 2))
    kw.update(
        noise=_off(_holdout_noise(rng), TUNE_NOISES),
        unit=_off(_r4(10 ** rng.uniform(-3, 3)), (1.0,)),
        tilt_deg=_off(_r4(rng.uniform(0, 60)), (0.0,)),
        tilt_axis_deg=_r4(rng.uniform(0, 180)),
        rotation_deg=_off(_r4(rng.uniform(0, 90)), TUNE_ROTATIONS),
    )
    recipe = (rng.choice(HOLDOUT_LAYOUTS), rng.uniform(0, 1, 4), rng.integers(0, 2))
    size = _off(_r4(rng.uniform(2, 8)), (4.0,))
    apex = rng.uniform(-0.5, 0.5, 2)
    for attempt in range(12):
        layout, params = _holdout_layout(recipe, size)
        case = new(fam, layout=layout, params=params, apex=tuple(_r4(v) for v in apex * size), **kw)
        if case is not None:
            return case
        if attempt < 4:
            apex = 0.5 * apex
        else:
            size = _off(_r4(max(2.0, 0.8 * size)), (4.0,))
    return None


def _holdout_noise(rng):
    """1 in 5 nearly noise-free (log-uniform 1e-5..1e-3), else uniform 0.001..0.03."""
    near_zero = rng.random() < 0.2
    return _r4(10 ** rng.uniform(-5, -3) if near_zero else rng.uniform(1e-3, 0.03))


def _holdout_object(fam, rng):
    """Object keywords: a log-uniform radius, a quadric's (k1, k2) or a plane's slope."""
    if fam == "plane":
        return {"slope": tuple(_r4(v) for v in rng.uniform(-2, 2, 2))}
    lo, hi = HOLDOUT_RADII[fam]
    r = _r4(10 ** rng.uniform(np.log10(lo), np.log10(hi)))
    if fam != "quadric":
        return {"radius": _off(r, TUNE_RADII + TUNE_CYLINDER_RADII)}
    ratio = rng.uniform(-0.95, 1.0)  # k2 / k1, never -1 (that is the saddle)
    return {"k": tuple(_r4(v) for v in rng.choice([-1.0, 1.0]) * np.array([1.0, ratio]) / r)}


def _holdout_layout(recipe, size):
    """(layout, params) of a held-out layout; ``recipe`` = (name, 4 uniforms, 0/1)."""
    name, u, pick = recipe
    angle = _r4(0.1 + 179.8 * u[0])
    short = _r4((0.4 + 0.6 * u[1]) * size)
    span, length = (size, short) if pick else (short, size)
    if name == "grid":
        nx, ny = (6, 6) if pick else (3, 9)
        return "grid", (("angle", angle), ("nx", nx), ("ny", ny), ("size", size))
    if name == "scatter":
        aspect = _r4(0.5 + 0.5 * u[1])
        return "scatter", (
            ("angle", angle),
            ("aspect", aspect),
            ("n", 27 + 9 * pick),
            ("size", size),
        )
    xs, stops = {
        "two_fingers": ((0.0, span), 18),
        "four_fingers": (tuple(_r4(v) for v in np.linspace(0, span, 4)), 9),
        "uneven": ((0.0, _r4((0.15 + 0.3 * u[2] + 0.4 * (u[2] > 0.5)) * span), span), 9 + 3 * pick),
        "twelve_stops": ((0.0, _r4(span / 2), span), 12),
    }[name]
    return "sweep", (("angle", angle), ("length", length), ("stops", stops), ("xs", xs))


# -- degenerate and inconsistent data ----------------------------------------------------

R10 = dict(radius=10.0)
C30 = dict(radius=10.0, rotation_deg=30.0)
DEGENERATE = (  # (reason, family, layout, params, object and frame keywords)
    ("line", "sphere", "line", {"n": 27}, R10),
    # the finger at x = 1 of a 0..4 sweep over a sphere r 10: a line 1 off the apex
    ("line", "sphere", "line", {"n": 36}, dict(R10, apex=(1.0, 0.0))),
    ("line", "cylinder", "line", {"angle": 45.0, "n": 36}, C30),
    ("line", "saddle", "line", {"angle": 30.0, "n": 27}, dict(R10, apex=(0.5, 1.0))),
    ("line", "plane", "line", {"n": 27}, dict(slope=(1.0, 1.0))),
    ("near_lines", "sphere", "sweep", {"stops": 18, "xs": (0.0, 0.004)}, R10),
    ("near_lines", "cylinder", "sweep", {"stops": 18, "xs": (0.0, 0.04)}, C30),
    ("cluster", "sphere", "cluster", {"n": 27}, R10),
    ("cluster", "cylinder", "cluster", {"n": 36, "spread": 0.05}, dict(C30, rotation_deg=45.0)),
    ("duplicates", "sphere", "duplicates", {"distinct": 2, "n": 36}, R10),
    ("duplicates", "cylinder", "duplicates", {"angle": 90.0, "distinct": 3, "n": 27}, R10),
    ("", "sphere", "sweep", THESIS27, dict(R10, normals_from="flat")),
    ("", "cylinder", "sweep", THESIS36, dict(R10, normals_from="flipped")),
    ("", "saddle", "sweep", THESIS27, dict(R10, normals_from="flipped")),
    ("", "plane", "sweep", THESIS36, dict(slope=(1.0, 1.0), normals_from="flipped")),
)
DEGENERATE_NOISES = (0.0, 0.005, 0.02)  # near lines and clusters: noisy only (exact data
# determine them)


def degenerate_cases():
    """Data that do not determine the curvature (``degenerate``) or contradict it
    (``inconsistent``); for the bench's refusal and confident-label counts."""
    out = []
    for reason, fam, layout, params, kw in DEGENERATE:
        noisy_only = reason in ("near_lines", "cluster")
        for s in DEGENERATE_NOISES[1:] if noisy_only else DEGENERATE_NOISES:
            out.append(new(fam, layout=layout, params=params, noise=s, degenerate=reason, **kw))
    return [c for c in out if c is not None]


def split(name):
    """Cases of a split by name: tune, holdout, holdout2-5, degenerate or all.

    ``holdout2`` is a second draw of the same recipe: the first holdout, once run, exposed
    two defects (a noise floor that biased low-noise k1, k2 together; model misfit read as
    positions/normals disagreement); after their fixes the method was judged on holdout2,
    which nothing had seen (docs/ep2.md).  ``holdout3``, a third draw that also draws the
    normals' noise apart from the positions' (the earlier splits tied them, and the noise
    estimate's cycling, issue 13, lay outside every split), judged its bracketed root.
    ``holdout4``, a fourth draw of holdout3's recipe, judged the 2-jet shrinkage designed
    while looking at holdout3's worst cases.  ``holdout5``, a fifth draw of the same recipe,
    judged the previous default's truncation view of its round model, designed while
    looking at holdout4's worst quadrics."""
    table = {
        "tune": tune_cases,
        "holdout": holdout_cases,
        "holdout2": lambda: holdout_cases(seed=HOLDOUT2_SEED),
        "holdout3": lambda: holdout_cases(seed=HOLDOUT3_SEED, ratios=True),
        "holdout4": lambda: holdout_cases(seed=HOLDOUT4_SEED, ratios=True),
        "holdout5": lambda: holdout_cases(seed=HOLDOUT5_SEED, ratios=True),
        "degenerate": degenerate_cases,
    }
    if name == "all":
        return [c for f in table.values() for c in f()]
    if name not in table:
        raise ValueError(f"unknown split {name!r} (choose {', '.join(table)} or all)")
    return table[name]()
