"""EP2 surface families: a case generator wider than ``cases``, on implicit surfaces.

A ``Case`` fixes a surface (``implicit.Surface``), a point on it, a layout of contacts
around it, the noise, whether the estimator is told the noise (``stated``), a length
``unit`` and, in the robust groups, which contacts are outliers and of what kind;
``draw(case, trial)`` gives one trial's contacts (noise and outlier sizes drawn from
sha256 of the case id and the trial, as ``cases.seed``), and ``truth(case, origins,
directions)`` the true k1 >= k2 and S where lines from an estimator's patch centre meet
the surface (the estimand of docs/ep2.md, "One definition everywhere").

Splits (``split(name)``), each drawn per case from a stable seed:

- ``tune``: estimators MAY be tuned on it.
- ``holdout``: FOR FINAL EVALUATION ONLY.  Never tune on it, never look at its per-case
  numbers while designing; run it once, when tuning is done.  Same recipe, another seed.
- ``robust_tune`` / ``robust_holdout``: the same recipe with 1 or 2 outliers per patch
  (``OUTLIER_KINDS``); ``robust_holdout`` is FOR FINAL EVALUATION ONLY, as ``holdout``.

Families (``FAMILIES``): sphere, pit, convex and concave cylinder, ellipsoid (axes up to
10:1, at a random point), torus at its outer equator, its inner equator (a saddle,
k = 1/r and -1/(R - r)) and any point, "cubic" height fields whose cubic terms are as
large as the quadratic ones over the patch (one in three with quartic terms too), quadrics
(k1, k2 of both signs, any rotation, at their apex), near-planes (|k| L in 1e-4..1e-2, tilted).
The patch size L makes |k|max L (at the centre point) log-uniform in 0.01..1.5 where the
family allows: a patch the surface does not reach, or whose normals stray beyond
``MAX_NORMAL_DEG`` from the centre normal, is shrunk by ``SHRINK`` until it fits.

Contacts: the layout (``family_layouts``) is laid in the centre's tangent plane and each
point taken to the surface along the centre normal (Newton on F); normal = grad F/|grad F|.
Noise: positions sigma = eps L on each coordinate, eps log-uniform in 0.001..0.02; normals
tilted by sigma_n rad per tangent axis, log-uniform in 0.001..0.03, drawn apart; one case
in seven noise-free.  The whole scene is then turned at random, shifted by a few L and
scaled by ``unit`` (1 mostly, 1e-3 or 1e3 in one case in six: scale invariance).
"""

import hashlib
from dataclasses import dataclass, field

import numpy as np

from tactile_sim.ep2.sweep import _tilt_normals
from tactile_studies.ep2 import family_layouts, implicit

FAMILIES = (
    "sphere",
    "pit",
    "cylinder",
    "concave_cylinder",
    "ellipsoid",
    "torus_outer",
    "torus_inner",
    "torus",
    "cubic",
    "quadric",
    "near_plane",
)
OUTLIER_KINDS = ("flipped", "off_surface", "other_face")
SPLITS = {  # name: (seed, cases per family, outliers)
    "tune": (90211, 160, False),
    "holdout": (57173, 80, False),  # FOR FINAL EVALUATION ONLY
    "robust_tune": (31337, 48, True),
    "robust_holdout": (86243, 48, True),  # FOR FINAL EVALUATION ONLY
}
KL_RANGE = (0.01, 1.5)
NEAR_PLANE_KL = (1e-4, 1e-2)
EPS_RANGE = (0.001, 0.02)  # position sigma / L
NORMAL_RANGE = (0.001, 0.03)  # rad per tangent axis
NOISE_FREE = 1 / 7
UNITS = (1e-3, 1.0, 1e3)
MAX_NORMAL_DEG = 80.0
SHRINK = 0.8


@dataclass(frozen=True, eq=False)
class Case:
    """One experiment: everything but the trial's noise and outlier sizes.  Geometry in the
    surface's own coordinates; ``draw`` turns, shifts and scales it to the data frame."""

    id: str
    split: str
    family: str
    surface: implicit.Surface
    centre: np.ndarray  # the chosen surface point (local)
    tangent: np.ndarray  # (3, 3): rows e1, e2, n of the centre's frame (local)
    layout: str  # family_layouts.KINDS
    clean: np.ndarray  # (n, 3) noise-free contacts (local)
    clean_normals: np.ndarray  # (n, 3)
    finger: np.ndarray
    size: float  # L: larger side of the layout's box in the tangent plane (local)
    kl: float  # |k|max L at the centre point
    eps: float  # position sigma / L (0: noise-free)
    sigma_n: float  # normal sigma (rad)
    stated: bool  # the estimator is told the noise
    unit: float
    rot: np.ndarray  # (3, 3) local -> data frame (before ``unit``)
    shift: np.ndarray  # (3,) data-frame offset of the centre point (local length)
    outliers: tuple = ()  # ((contact index, kind), ...)
    well_posed: bool = True  # the data determine the curvature (``family_score``)
    notes: dict = field(default_factory=dict)

    @property
    def n(self):
        return len(self.clean)

    @property
    def noise_bin(self):
        """none, low (eps < 0.003), mid (eps < 0.01) or high: by the position noise over L
        (the normals' sigma is drawn apart and spread over every bin)."""
        if self.eps == 0:
            return "none"
        return "low" if self.eps < 0.003 else "mid" if self.eps < 0.01 else "high"

    @property
    def trials_needed(self):
        """Trials that differ: one for a noise-free case without outliers."""
        return 1 if self.noise_bin == "none" and not self.outliers else None

    @property
    def label(self):
        """A readable one-line description (not part of the seed)."""
        out = " ".join(f"{i}:{k}" for i, k in self.outliers)
        return (
            f"{self.id} {self.layout} n={self.n} kL={self.kl:.3g} eps={self.eps:.3g}"
            f" sn={self.sigma_n:.3g} {'stated' if self.stated else 'unstated'} u={self.unit:g}"
            + (f" outliers={out}" if out else "")
        )


def seed(text):
    """Stable 64-bit seed from text (sha256, not Python's salted ``hash``)."""
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


def _rotation(rng):
    """A uniformly random rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _loguniform(rng, lo, hi):
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))


def _quadratic(k_a, k_b, angle):
    """Coefficients (x^2, xy, y^2) of h = -(k_a u^2 + k_b v^2)/2, (u, v) turned by angle."""
    c, s = np.cos(angle), np.sin(angle)
    return (
        -0.5 * (k_a * c * c + k_b * s * s),
        -(k_a - k_b) * c * s,
        -0.5 * (k_a * s * s + k_b * c * c),
    )


def _height(rng, kl, family):
    """(surface, centre, L) of a height-field family with max|k| ~ 1 at the origin."""
    L = kl
    sign = rng.choice([-1.0, 1.0])
    coef = np.zeros((5, 5))
    coef[2, 0], coef[1, 1], coef[0, 2] = _quadratic(
        sign, sign * rng.uniform(-1, 1), rng.uniform(0, np.pi)
    )
    if family in ("cubic", "near_plane"):
        coef[1, 0], coef[0, 1] = rng.uniform(-0.8, 0.8, 2)  # a tilted centre, off the apex
    if family == "cubic":  # cubic terms as large as the quadratic ones at |x| = L/2
        for i in range(4):
            coef[3 - i, i] = rng.standard_normal() * rng.uniform(0.5, 1.5) / L
        if rng.random() < 1 / 3:
            for i in range(5):
                coef[4 - i, i] = rng.standard_normal() * rng.uniform(0.5, 1.5) * 2 / L**2
    return implicit.height(coef), np.zeros(3), L


def _object(family, rng):
    """(surface, centre point, L, kl wanted) for ``family`` (module docstring)."""
    lo, hi = NEAR_PLANE_KL if family == "near_plane" else KL_RANGE
    kl = _loguniform(rng, lo, hi)
    if family in ("cubic", "quadric", "near_plane"):
        return (*_height(rng, kl, family), kl)
    if family in ("sphere", "pit"):
        surf = implicit.Surface("sphere", (1.0 if family == "sphere" else -1.0, 1.0))
        d = rng.standard_normal(3)
        centre = d / np.linalg.norm(d)
    elif family in ("cylinder", "concave_cylinder"):
        surf = implicit.Surface("cylinder", (1.0 if family == "cylinder" else -1.0, 1.0))
        t = rng.uniform(0, 2 * np.pi)
        centre = np.array([np.cos(t), np.sin(t), rng.uniform(-1, 1)])
    elif family == "ellipsoid":
        axes = rng.permutation([1.0, 10 ** -rng.uniform(0, 1), 10 ** -rng.uniform(0, 1)])
        surf = implicit.Surface("ellipsoid", tuple(float(a) for a in axes))
        d = rng.standard_normal(3)
        centre = d / np.sqrt(np.sum(d**2 / axes**2))
    else:
        big, r = 1.0, rng.uniform(0.2, 0.6)
        surf = implicit.Surface("torus", (big, r))
        theta = {"torus_outer": 0.0, "torus_inner": np.pi}.get(family, rng.uniform(0, 2 * np.pi))
        phi = rng.uniform(0, 2 * np.pi)
        rho = big + r * np.cos(theta)
        centre = np.array([rho * np.cos(phi), rho * np.sin(phi), r * np.sin(theta)])
    k1, k2 = implicit.principal(surf, centre[None])
    return surf, centre, kl / max(abs(k1[0]), abs(k2[0])), kl


def _contacts(surf, centre, tangent, uv, L):
    """(points, normals) on the surface under ``centre`` + L uv along the centre normal, or
    None where a line misses or a normal strays beyond ``MAX_NORMAL_DEG``."""
    starts = centre + L * uv @ tangent[:2]
    pts, ok = implicit.line_root(surf, starts, np.tile(tangent[2], (len(uv), 1)), L)
    if not ok.all():
        return None
    nrm = implicit.normals(surf, pts)
    if np.min(nrm @ tangent[2]) < np.cos(np.radians(MAX_NORMAL_DEG)):
        return None
    return pts, nrm


def make_case(split, family, index):
    """Case ``index`` of ``family`` in ``split`` (deterministic from the split's seed)."""
    split_seed, _, robust = SPLITS[split]
    rng = np.random.default_rng(seed(f"{split_seed}:{family}:{index}"))
    surf, centre, L, _ = _object(family, rng)
    n0 = implicit.normals(surf, centre[None])[0]
    tangent = np.vstack([implicit.tangent_basis(n0[None])[0].T, n0])
    layout = family_layouts.KINDS[index % len(family_layouts.KINDS)]
    uv, finger = family_layouts.place(layout, rng)
    for _ in range(40):
        got = _contacts(surf, centre, tangent, uv, L)
        if got is not None:
            break
        L *= SHRINK
    else:
        raise RuntimeError(f"{split}:{family}:{index}: no patch fits")
    k1, k2 = implicit.principal(surf, centre[None])
    free = rng.random() < NOISE_FREE
    eps = 0.0 if free else _loguniform(rng, *EPS_RANGE)
    sigma_n = 0.0 if free else _loguniform(rng, *NORMAL_RANGE)
    outliers = ()
    if robust:
        idx = rng.choice(len(uv), size=int(rng.integers(1, 3)), replace=False)
        outliers = tuple((int(i), str(rng.choice(OUTLIER_KINDS))) for i in sorted(idx))
    return Case(
        id=f"{split}:{family}:{index}",
        split=split,
        family=family,
        surface=surf,
        centre=centre,
        tangent=tangent,
        layout=layout,
        clean=got[0],
        clean_normals=got[1],
        finger=finger,
        size=float(L),
        kl=float(max(abs(k1[0]), abs(k2[0])) * L),
        eps=eps,
        sigma_n=sigma_n,
        stated=bool(rng.random() < 0.5),
        unit=float(rng.choice(UNITS, p=(1 / 12, 5 / 6, 1 / 12))),
        rot=_rotation(rng),
        shift=rng.uniform(-5, 5, 3) * L,
        outliers=outliers,
    )


def _turn_about_tangent(n, angle, rng):
    """Unit normals (m, 3) turned by ``angle`` (m,) rad about a random tangent axis each."""
    T = implicit.tangent_basis(n)
    phi = rng.uniform(0, 2 * np.pi, len(n))
    axis = np.cos(phi)[:, None] * T[..., 0] + np.sin(phi)[:, None] * T[..., 1]
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return c * n + s * np.cross(axis, n)  # the axis is perpendicular to n


def draw(case, trial=0):
    """One trial: dict of ``points``, ``normals`` (data frame, with noise and outliers),
    ``finger``, ``noise_pos`` (data unit), ``noise_normal`` (rad), ``stated``, ``outliers``
    ((index, kind) pairs), ``inliers`` (indices of the other contacts) and ``seed``."""
    s = seed(f"{case.id}#{trial}")
    rng = np.random.default_rng(s)
    L = case.size
    pts = case.clean + case.eps * L * rng.standard_normal(case.clean.shape)
    nrm = case.clean_normals
    if case.sigma_n > 0:
        nrm = _tilt_normals(nrm, case.sigma_n, rng)
    pts, nrm = pts.copy(), nrm.copy()
    for i, kind in case.outliers:
        if kind == "flipped":
            nrm[i] = _turn_about_tangent(nrm[i : i + 1], np.radians([rng.uniform(150, 180)]), rng)
        elif kind == "off_surface":
            pts[i] += rng.choice([-1, 1]) * rng.uniform(0.1, 0.3) * L * case.clean_normals[i]
        else:
            nrm[i] = _turn_about_tangent(nrm[i : i + 1], np.radians([rng.uniform(60, 120)]), rng)
            d = rng.standard_normal(3)
            pts[i] += rng.uniform(0.05, 0.2) * L * d / np.linalg.norm(d)
    bad = {i for i, _ in case.outliers}
    return {
        "points": case.unit * ((pts - case.centre) @ case.rot.T + case.shift),
        "normals": nrm @ case.rot.T,
        "finger": case.finger,
        "noise_pos": case.eps * L * case.unit,
        "noise_normal": case.sigma_n,
        "stated": case.stated,
        "outliers": case.outliers,
        "inliers": np.array([i for i in range(case.n) if i not in bad], int),
        "seed": s,
    }


def to_local(case, points, directions):
    """Data-frame points and directions back to the surface's own coordinates."""
    p = (np.atleast_2d(points) / case.unit - case.shift) @ case.rot + case.centre
    return p, np.atleast_2d(directions) @ case.rot


def truth(case, origins, directions):
    """True k1 >= k2 (1/data unit) and S where the lines origin + s direction (data frame)
    meet the surface: ``implicit.truth_along``'s dict, ``point`` in the data frame."""
    o, d = to_local(case, origins, directions)
    out = implicit.truth_along(case.surface, o, d, case.size)
    out["k1"], out["k2"] = out["k1"] / case.unit, out["k2"] / case.unit
    out["point"] = case.unit * ((out["point"] - case.centre) @ case.rot.T + case.shift)
    return out


def nominal_truth(case):
    """Truth at the chosen centre point along its normal (no estimator involved)."""
    origin = case.unit * case.shift
    return truth(case, origin[None], (case.tangent[2] @ case.rot.T)[None])


def split(name, per_family=None):
    """The cases of split ``name`` (``SPLITS``), ``per_family`` of each family (default the
    split's own count).  Holdout splits are FOR FINAL EVALUATION ONLY (module docstring)."""
    if name not in SPLITS:
        raise ValueError(f"unknown split {name!r} (choose {', '.join(SPLITS)})")
    count = SPLITS[name][1] if per_family is None else per_family
    return [make_case(name, fam, i) for fam in FAMILIES for i in range(count)]
