"""EP2 simulation studies: replicas of figs. 30-34 (§4.9) and tables 5-7 (§5.2).

Layout as in §4.9: the patch spans [0, 4] x [0, 4] with the object's apex at
the corner (0, 0) (radius 5.7, the thesis's smallest, just clears the far
corner at 4 sqrt 2 = 5.66); three fingers 2 apart, 6 stops x 2 readings.
Each study returns rows (dicts); ``run(name, out)`` runs one of ``STUDIES`` and
writes its CSV and (unless ``png`` is False) its PNG (``tactile_studies.ep2.plots``),
returning the rows and the paths written.  Columns hold the thesis's statistic
(grid mean and std of S) and this implementation's ``S`` (at the patch centre)
and label.
"""

import csv
import os

import numpy as np

from tactile.ep2 import analyze_patch
from tactile.errors import DataError
from tactile.files.writing import atomic_write
from tactile_sim.ep2.objects import make
from tactile_sim.ep2.sweep import sweep
from tactile_studies.ep2 import plots

ROTATIONS = (0, 10, 30, 45, 60, 80, 90)
RADII = (5.7, 6, 7, 8, 9, 10, 20, 40, 80, 150, 300, 500, 1000)
UNITS = (
    "lengths cm, R and curvatures 1/cm, angles deg (rotation), S and spline_degree dimensionless"
)
THESIS_LAYOUT = {"centre": (0.0, 0.0)}


def _analyse(obj, degree, weighting, maps=False, **sweep_kw):
    d = sweep(obj, **sweep_kw)
    try:
        return analyze_patch(
            d["points"],
            d["normals"],
            method="spline",
            order=degree,
            weighting=weighting,
            max_normal_angle=89.0,
            maps=maps,
        )
    except DataError:
        return None


def _row(res, **keys):
    if res is None:
        return {**keys, "shape": "error", "S_mean": None, "S_std": None, "S": None}
    return {
        **keys,
        "shape": res.shape,
        "S_mean": res.S_mean,
        "S_std": res.S_std,
        "S": res.S,
        "R_mean": res.R_mean,
        "radius_est": res.radius,
    }


def cylinders():
    """Fig. 30/31: convex cylinders R 6, 10, 500 x 7 rotations, bicubic, tangent/position."""
    rows = []
    for radius in (6, 10, 500):
        for rot in ROTATIONS:
            obj = make("cylinder", radius, rot, **THESIS_LAYOUT)
            for w in ("tangent", "position", "auto"):
                deg = 3 if w != "auto" else 2
                rows.append(
                    _row(
                        _analyse(obj, deg, w),
                        radius=radius,
                        rotation=rot,
                        weighting=w,
                        spline_degree=deg,
                    )
                )
    return rows


def rotation():
    """Fig. 32: RMS over the grid of S - 0.5 against rotation, R 6, 10, 20 (bicubic, tangent)."""
    rows = []
    for radius in (6, 10, 20):
        for rot in ROTATIONS:
            obj = make("cylinder", radius, rot, **THESIS_LAYOUT)
            for w, deg in (("tangent", 3), ("auto", 2)):
                res = _analyse(obj, deg, w, maps=True)
                rms = None
                if res is not None and "S" in res.maps:
                    rms = float(np.sqrt(np.mean((res.maps["S"] - 0.5) ** 2)))
                rows.append(
                    {
                        "radius": radius,
                        "rotation": rot,
                        "weighting": w,
                        "spline_degree": deg,
                        "rms_S_error": rms,
                        "S_error": None if res is None or res.S is None else res.S - 0.5,
                    }
                )
    return rows


def radius_sweep(kind="cylinder"):
    """Fig. 33 (cylinders at 45 deg) / fig. 34 (spheres): S against radius x order x weighting."""
    rows = []
    for radius in RADII:
        obj = make(kind, radius, 45.0 if kind == "cylinder" else 0.0, **THESIS_LAYOUT)
        for deg in (2, 3, 4):
            for w in ("tangent", "position", "auto"):
                rows.append(
                    _row(_analyse(obj, deg, w), radius=radius, spline_degree=deg, weighting=w)
                )
    return rows


THESIS_TABLES = {
    ("plane", "tangent"): (0.4703, 0.21204, 0.004114, None),
    ("plane", "position"): (0.3643, 0.24721, 0.003026, None),
    ("cylinder", "tangent"): (0.4980, 0.009639, 0.080290, 8.8078),
    ("cylinder", "position"): (0.5014, 0.015773, 0.073446, 9.6304),
    ("concave_cylinder", "tangent"): (-0.4878, 0.036813, 0.057014, 12.4155),
    ("concave_cylinder", "position"): (-0.4483, 0.123840, 0.053336, 13.4831),
}


def tables(trials=50, noise_pos=0.05, noise_normal=0.03, spacing=2.5, length=6.0):
    """Tables 5-7 in simulation: plane, convex cylinder R 6.6 cm, concave R 11.25 cm.

    36 contacts (3 passes x 6 stops x 2 readings), biquadratic, 8 x 8 grid, tangent
    and position weighting (§5.2).  The experiment's noise and sweep size are not in
    the thesis; the defaults here (0.05 cm, 0.03 rad, fingers 2.5 cm apart, 6 cm
    sweep) are assumptions.  Means over ``trials`` seeds.
    """
    rows = []
    for kind, radius in (("plane", 1.0), ("cylinder", 6.6), ("concave_cylinder", 11.25)):
        obj = make(kind, radius, 0.0, centre=(spacing, length / 2))
        for w in ("tangent", "position", "auto"):
            acc = {"S_mean": [], "S_std": [], "R_mean": [], "R_std": [], "radius": [], "labels": []}
            for t in range(trials):
                d = sweep(
                    obj,
                    spacing=spacing,
                    length=length,
                    noise_pos=noise_pos,
                    noise_normal=noise_normal,
                    seed=t,
                )
                r = analyze_patch(
                    d["points"], d["normals"], method="spline", order=2, weighting=w, maps=True
                )
                k1, k2 = r.maps["k1"], r.maps["k2"]
                s = 2 / np.pi * np.arctan2(k1 + k2, k1 - k2)  # computed even for planes
                rr = np.hypot(k1, k2) / np.sqrt(2)
                acc["S_mean"].append(s.mean())
                acc["S_std"].append(s.std())
                acc["R_mean"].append(rr.mean())
                acc["R_std"].append(rr.std())
                acc["radius"].append(r.radius if r.radius is not None else np.nan)
                acc["labels"].append(r.shape)
            thesis = THESIS_TABLES.get((kind, w), (None,) * 4)
            labels = acc.pop("labels")
            row = {
                "surface": kind,
                "true_radius": None if kind == "plane" else radius,
                "weighting": w,
            }
            row.update(
                {k: float(np.nanmean(v)) if np.isfinite(v).any() else None for k, v in acc.items()}
            )
            row["label_share"] = float(np.mean([lab == _expected(kind) for lab in labels]))
            row.update(
                thesis_S=thesis[0],
                thesis_S_std=thesis[1],
                thesis_R=thesis[2],
                thesis_radius=thesis[3],
            )
            rows.append(row)
    return rows


def _expected(kind):
    return {"plane": "plane", "cylinder": "cylinder", "concave_cylinder": "concave_cylinder"}[kind]


# study -> (function, its keywords, file stem, plot function in tactile_studies.ep2.plots)
STUDIES = {
    "cylinders": (cylinders, {}, "ep2_fig30_cylinders", "plot_cylinders"),
    "rotation": (rotation, {}, "ep2_fig32_rotation", "plot_rotation"),
    "cylinder-radius": (
        radius_sweep,
        {"kind": "cylinder"},
        "ep2_fig33_cylinder_radius",
        "plot_cylinder_radius",
    ),
    "sphere-radius": (
        radius_sweep,
        {"kind": "sphere"},
        "ep2_fig34_sphere_radius",
        "plot_sphere_radius",
    ),
    "tables": (tables, {}, "ep2_tables5_7", "plot_tables"),
}


def run(name, out, png=True, **kw):
    """Run study ``name`` (a key of ``STUDIES``; ``kw`` goes to it), write OUT/STEM.csv and,
    if ``png``, OUT/STEM.png.  Returns (rows, paths written)."""
    fn, fixed, stem, plot = STUDIES[name]
    rows = fn(**fixed, **kw)
    paths = [_write(out, stem, rows)]
    if png:
        paths.append(getattr(plots, plot)(rows, os.path.join(out, stem + ".png")))
    return rows, paths


def _write(out, name, rows):
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, name + ".csv")
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with atomic_write(path, text=True, newline="") as fh:
        fh.write(f"# units: {UNITS}\n")
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in keys})
    return path
