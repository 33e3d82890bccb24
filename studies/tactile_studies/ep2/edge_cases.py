"""Held-out EP2 cases where a real object differs from a smooth patch (bench/ep2_edges.py).

Kinds (``KINDS``), each drawn from its own seed, split by seed into ``tune`` (for tuning)
and ``holdout`` (FOR FINAL EVALUATION ONLY):

- ``ridge``, ``valley``: two planar faces meeting along a straight edge at a dihedral angle
  of 30-150 deg (the angle between the faces; the normals turn by 180 minus it), the edge
  0-0.25 L off the layout's middle; sweeps, grids and scatters laid out in arc length.
- ``join``: a plane joined tangentially to a cylinder (convex or concave) of radius
  0.6-4 L: a curvature jump; the truth at a point is the side it lies on.
- ``drift``: a smooth ``families`` case swept by fingers, its positions biased by a drift
  growing along the sweep up to 3 x the position noise (a force sensor's slow bias), its
  normals by up to 3 x theirs.
- ``tilt``: a smooth ``families`` case whose normals are all turned by one 2-5 deg
  rotation about a tangent axis (a mis-tared or weighted sensor).
- ``small``: a smooth ``families`` case cut to its first 4-5 contacts.

A crease or join case is a dict (``points``, ``normals``, ``finger``, ``noise_pos``,
``noise_normal``, ``stated``, ``truth``); a smooth one also holds its ``families.Case``
(``case``) for ``family_score``'s truth.  Lengths are in units of L (the layout's larger
side) times a random unit, turned and shifted at random.
"""

import dataclasses

import numpy as np

from tactile_sim.ep2.sweep import _tilt_normals
from tactile_studies.ep2 import families, family_layouts

KINDS = ("ridge", "valley", "join", "drift", "tilt", "small")
SPLITS = {"tune": 40417, "holdout": 72931}  # holdout: FOR FINAL EVALUATION ONLY
CREASE_LAYOUTS = ("sweep", "scatter", "grid")
DIHEDRAL_DEG = (30.0, 150.0)
TILT_DEG = (2.0, 5.0)
DRIFT_X = 3.0  # the drift's largest size over the noise
SMOOTH = ("sphere", "pit", "cylinder", "concave_cylinder", "ellipsoid", "torus", "quadric")
_FAMILY_INDEX = {"tune": 10_000, "holdout": 20_000}  # beyond every families split's count


def _rng(split, kind, index):
    return np.random.default_rng(families.seed(f"{SPLITS[split]}:{kind}:{index}"))


def _noise(rng, data):
    eps = families._loguniform(rng, *families.EPS_RANGE)
    sigma_n = families._loguniform(rng, *families.NORMAL_RANGE)
    stated = bool(rng.random() < 0.5)
    data["points"] = data["points"] + eps * rng.standard_normal(data["points"].shape)
    data["normals"] = _tilt_normals(data["normals"], sigma_n, rng)
    data.update(noise_pos=eps, noise_normal=sigma_n, stated=stated)


def _place(rng, data):
    """Turn, shift and scale a local case (lengths in L) into a data frame."""
    rot = families._rotation(rng)
    unit = float(rng.choice(families.UNITS, p=(1 / 12, 5 / 6, 1 / 12)))
    shift = rng.uniform(-5, 5, 3)
    data["points"] = unit * (data["points"] @ rot.T + shift)
    data["normals"] = data["normals"] @ rot.T
    data["noise_pos"] *= unit
    data.update(unit=unit, rot=rot, shift=shift)
    t = data["truth"]
    if "point" in t:
        t["point"] = unit * (t["point"] @ rot.T + shift)
        t["direction"] = t["direction"] @ rot.T


def _layout(rng, index, min_each=3, offset=0.25):
    """(uv, finger, offset): a layout whose u = offset splits it with min_each a side."""
    kind = CREASE_LAYOUTS[index % len(CREASE_LAYOUTS)]
    while True:
        uv, finger = family_layouts.place(kind, rng)
        off = rng.uniform(-offset, offset)
        left = int(np.sum(uv[:, 0] < off))
        if min(left, len(uv) - left) >= min_each:
            return kind, uv, finger, off


def crease(split, kind, index):
    """A ``ridge`` or ``valley`` case: edge along local y through the origin."""
    rng = _rng(split, kind, index)
    layout, uv, finger, off = _layout(rng, index)
    dihedral = rng.uniform(*DIHEDRAL_DEG)
    half = np.radians(180.0 - dihedral) / 2
    c, s = np.cos(half), np.sin(half)
    sign = -1.0 if kind == "ridge" else 1.0  # ridge: the faces fall away from the edge
    u = uv[:, 0] - off
    left = u < 0
    pts = np.column_stack([u * c, uv[:, 1], sign * np.abs(u) * s])
    nrm = np.where(left[:, None], [[sign * s, 0.0, c]], [[-sign * s, 0.0, c]])
    truth = {"kind": kind, "dihedral_deg": dihedral, "point": np.zeros((1, 3))}
    truth["direction"] = np.array([[0.0, 1.0, 0.0]])
    data = {"id": f"{split}:{kind}:{index}", "kind": kind, "layout": layout, "truth": truth,
            "points": pts, "normals": nrm, "finger": finger}  # fmt: skip
    _noise(rng, data)
    _place(rng, data)
    return data


def join(split, index):
    """A plane (local u < 0) joined tangentially to a cylinder of radius R (u > 0)."""
    rng = _rng(split, "join", index)
    layout, uv, finger, off = _layout(rng, index, min_each=2, offset=0.3)
    R = rng.uniform(0.6, 4.0)
    sign = rng.choice([-1.0, 1.0])  # +1 convex (k1 = 1/R), -1 concave (k2 = -1/R)
    u = uv[:, 0] - off
    phi = np.maximum(u, 0.0) / R
    x = np.where(u < 0, u, R * np.sin(phi))
    z = np.where(u < 0, 0.0, -sign * R * (1 - np.cos(phi)))
    pts = np.column_stack([x, uv[:, 1], z])
    nrm = np.column_stack([sign * np.sin(phi), np.zeros_like(phi), np.cos(phi)])
    truth = {"kind": "join", "R": R, "sign": sign}
    data = {"id": f"{split}:join:{index}", "kind": "join", "layout": layout, "truth": truth,
            "points": pts, "normals": nrm, "finger": finger}  # fmt: skip
    _noise(rng, data)
    _place(rng, data)
    return data


def join_truth(data, point):
    """(k1, k2, S) in 1/data unit at a data-frame point of a ``join`` case: the side of the
    join the point lies on (S None on the plane)."""
    local = (np.asarray(point, float) / data["unit"] - data["shift"]) @ data["rot"]
    t = data["truth"]
    if local[0] < 0:
        return 0.0, 0.0, None
    k = 1.0 / (t["R"] * data["unit"])
    return (k, 0.0, 0.5) if t["sign"] > 0 else (0.0, -k, -0.5)


def smooth(split, kind, index):
    """A ``drift``, ``tilt`` or ``small`` case: a ``families`` case, then its error."""
    rng = _rng(split, kind, index)
    family = SMOOTH[index % len(SMOOTH)]
    # families' layouts cycle sweep, grid, scatter, small: a drift needs a sweep
    base = _FAMILY_INDEX[split] + 4 * index + (3 if kind == "small" else 0)
    case = families.make_case("tune", family, base)
    if case.eps == 0:
        case = _with(case, eps=families._loguniform(rng, *families.EPS_RANGE))
    if case.sigma_n == 0:
        case = _with(case, sigma_n=families._loguniform(rng, *families.NORMAL_RANGE))
    if kind == "small":
        m = int(rng.integers(4, 6))
        case = _with(case, clean=case.clean[:m], clean_normals=case.clean_normals[:m],
                     finger=case.finger[:m])  # fmt: skip
    data = families.draw(case)
    data.update(id=f"{split}:{kind}:{index}", kind=kind, layout=case.layout, case=case)
    data["truth"] = {"kind": kind, "family": family}
    if kind == "drift":
        _drift(rng, case, data)
    elif kind == "tilt":
        _tilt(rng, data)
    return data


def _with(case, **kw):
    return dataclasses.replace(case, **kw)


def _drift(rng, case, data):
    """Positions and normals biased by a drift growing along the sweep (row order)."""
    n = case.n
    ramp = np.linspace(0.0, 1.0, n)[:, None]
    d = rng.standard_normal(3)
    size = rng.uniform(1.0, DRIFT_X)
    data["points"] = data["points"] + ramp * size * data["noise_pos"] * d / np.linalg.norm(d)
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    angle = ramp * rng.uniform(1.0, DRIFT_X) * case.sigma_n
    nrm = data["normals"]
    turned = nrm * np.cos(angle) + np.cross(axis, nrm) * np.sin(angle)
    data["normals"] = turned / np.linalg.norm(turned, axis=1, keepdims=True)
    data["truth"]["drift"] = float(size)


def _tilt(rng, data):
    """Every normal turned by one rotation of 2-5 deg about an axis across the patch."""
    nrm = data["normals"]
    mean = nrm.mean(axis=0)
    mean /= np.linalg.norm(mean)
    axis = np.cross(mean, rng.standard_normal(3))
    axis /= np.linalg.norm(axis)
    deg = rng.uniform(*TILT_DEG)
    a = np.radians(deg)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
    data["normals"] = nrm @ rot.T
    data["truth"]["tilt_deg"] = float(deg)


def make(split, kind, index):
    """Case ``index`` of ``kind`` in ``split``."""
    if kind in ("ridge", "valley"):
        return crease(split, kind, index)
    if kind == "join":
        return join(split, index)
    return smooth(split, kind, index)


def cases(split, per_kind, kinds=KINDS):
    """``per_kind`` cases of each kind in ``split``."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r} (choose {', '.join(SPLITS)})")
    return [make(split, k, i) for k in kinds for i in range(per_kind)]
