"""PNG figures for the EP2 studies (``tactile_studies.ep2.studies``): thesis figs. 30, 32, 33,
34 and tables 5-7.

As in §4.9, each point is the mean of S over the analysis grid and its bar the standard
deviation (STD) of S over the grid.  S is dimensionless; lengths are in the thesis's
units (the patch spans 4 x 4, §4.9) or cm (tables 5-7, ch. 5).  Each function takes the
study's rows and a path, writes the PNG and returns the path; matplotlib (Agg) is imported
when one is called.
"""

import numpy as np

from tactile.errors import pyplot
from tactile_studies.figures import place_legend, save

__all__ = [
    "plot_cylinder_radius",
    "plot_cylinders",
    "plot_rotation",
    "plot_sphere_radius",
    "plot_tables",
]

WEIGHTINGS = ("tangent", "position", "auto")
ORDER_NAME = {2: "biquadratic", 3: "bicubic", 4: "biquartic"}
S_LABEL = "S: grid mean \u00b1 STD (dimensionless)"
LENGTH = "length unit"


def _figure(n, width=3.6, height=3.4, sharey=True, ratios=None):
    plt = pyplot()

    fig, axes = plt.subplots(
        1,
        n,
        figsize=(width * (n if ratios is None else sum(ratios)) + 1.8, height),
        squeeze=False,
        sharey=sharey,
        layout="constrained",
        gridspec_kw=None if ratios is None else {"width_ratios": ratios},
    )
    return plt, fig, axes[0]


def _value(row, key):
    v = row.get(key)
    return np.nan if v is None else float(v)


def _errorbars(ax, rows, xkey, label, width=0.25):
    """Mean S with +-STD bars, one series per weighting at each value of ``xkey`` (as
    equally spaced categories, ``width`` apart so no bar hides another); returns the
    sorted category values."""
    values = sorted({r[xkey] for r in rows})
    for i, w in enumerate(WEIGHTINGS):
        sel = sorted((r for r in rows if r["weighting"] == w), key=lambda r: r[xkey])
        if not sel:
            continue
        x = np.array([values.index(r[xkey]) for r in sel]) + width * (i - 1)
        y = np.array([_value(r, "S_mean") for r in sel])
        e = np.array([_value(r, "S_std") for r in sel])
        ok = np.isfinite(y)
        ax.errorbar(
            x[ok], y[ok], yerr=np.nan_to_num(e[ok]), fmt="o", ms=3.5, capsize=2, lw=1,
            label=label(w, sel[0]),
        )  # fmt: skip
    ax.set_xticks(range(len(values)), [f"{v:g}" for v in values])
    ax.set_xlim(-0.6, len(values) - 0.4)
    return values


def _truth(ax, s, what):
    ax.axhline(s, color="k", lw=0.6, ls="--", label=f"true S = {s:g} ({what})")


def plot_cylinders(rows, path):
    """Fig. 30: mean S +- STD against rotation, one panel per radius."""
    radii = sorted({r["radius"] for r in rows})
    plt, fig, axes = _figure(len(radii))
    for ax, radius in zip(axes, radii, strict=True):
        sub = [r for r in rows if r["radius"] == radius]
        _errorbars(ax, sub, "rotation", _weighting_label)
        _truth(ax, 0.5, "cylinder")
        ax.set_title(f"radius {radius:g} ({LENGTH})", fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_ylabel(S_LABEL)
    fig.supxlabel("cylinder rotation about the patch normal (deg)", fontsize=10)
    place_legend(axes[-1])
    fig.suptitle(
        "Thesis fig. 30: S of convex cylinders against rotation\n(points: mean of S over the"
        " grid; bars: \u00b1 STD)",
        fontsize=10,
    )
    return save(plt, fig, path)[0]


def _weighting_label(w, row):
    return f"{w} weighting, {ORDER_NAME.get(row['spline_degree'], row['spline_degree'])}"


def plot_rotation(rows, path):
    """Fig. 32: RMS over the grid of S - 0.5 against rotation, one line per radius and fit."""
    plt, fig, (ax,) = _figure(1, width=5.0)
    keys = sorted({(r["radius"], r["weighting"], r["spline_degree"]) for r in rows})
    for n, (radius, w, deg) in enumerate(keys):
        sel = sorted(
            (
                r
                for r in rows
                if (r["radius"], r["weighting"], r["spline_degree"]) == (radius, w, deg)
            ),
            key=lambda r: r["rotation"],
        )
        ax.plot(
            [r["rotation"] for r in sel],
            [_value(r, "rms_S_error") for r in sel],
            marker="o", ms=3, lw=1.2, color=f"C{n // 2}", ls="-" if w == "tangent" else "--",
            label=f"radius {radius:g}, {w}, {ORDER_NAME.get(deg, deg)}",
        )  # fmt: skip
    ax.set_xticks(sorted({r["rotation"] for r in rows}))
    ax.set(xlabel="cylinder rotation (deg)", ylabel="RMS over the grid of S - 0.5 (dimensionless)")
    ax.grid(True, alpha=0.3)
    place_legend(ax, title=f"cylinder radius ({LENGTH}), fit", title_fontsize=8)
    fig.suptitle("Thesis fig. 32: RMS error in S against cylinder rotation", fontsize=10)
    return save(plt, fig, path)[0]


def _radius_figure(rows, path, true_s, what, title):
    """One row per fit order, the radii as categories (as the thesis's bar charts)."""
    plt = pyplot()

    degrees = sorted({r["spline_degree"] for r in rows})
    fig, axes = plt.subplots(
        len(degrees), 1, figsize=(8.6, 2.3 * len(degrees) + 0.9), sharex=True,
        squeeze=False, layout="constrained",
    )  # fmt: skip
    axes = axes[:, 0]
    for ax, deg in zip(axes, degrees, strict=True):
        sub = [r for r in rows if r["spline_degree"] == deg]
        _errorbars(ax, sub, "radius", lambda w, _: f"{w} weighting")
        _truth(ax, true_s, what)
        ax.set_ylabel(f"{ORDER_NAME.get(deg, deg)}\nS (dimensionless)", fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
    axes[-1].set_xlabel(f"{what} radius ({LENGTH}; the patch spans 4 x 4)")
    place_legend(axes[0])
    fig.suptitle(f"{title}\n(points: mean of S over the grid; bars: \u00b1 STD)", fontsize=10)
    return save(plt, fig, path)[0]


def plot_cylinder_radius(rows, path):
    """Fig. 33: mean S +- STD of cylinders rotated 45 deg against radius, one panel per order."""
    title = "Thesis fig. 33: S of cylinders rotated 45\u00b0 against radius"
    return _radius_figure(rows, path, 0.5, "cylinder", title)


def plot_sphere_radius(rows, path):
    """Fig. 34: mean S +- STD of spheres against radius, one panel per order."""
    return _radius_figure(rows, path, 1.0, "sphere", "Thesis fig. 34: S of spheres against radius")


SURFACES = (("plane", None), ("cylinder", 0.5), ("concave_cylinder", -0.5))


def plot_tables(rows, path):
    """Tables 5-7: S (mean +- STD over the grid, mean over trials) and the radius per surface
    and weighting, this simulation beside the thesis's experiment."""
    plt, fig, axes = _figure(4, width=2.7, height=3.3, sharey=False, ratios=(1, 1, 1, 1.6))
    for ax, (surface, true_s) in zip(axes[:3], SURFACES, strict=True):
        ax.sharey(axes[0])
        sub = [r for r in rows if r["surface"] == surface]
        _pairs(ax, sub, "S_mean", "S_std", "thesis_S", "thesis_S_std")
        if true_s is not None:
            _truth(ax, true_s, surface.replace("_", " "))
        ax.set_title(_surface_title(sub[0] if sub else {"surface": surface}), fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_ylabel(S_LABEL)
    ax = axes[3]
    cylinders = [r for r in rows if r["surface"] != "plane"]
    _pairs(ax, cylinders, "radius", None, "thesis_radius", None, by_surface=True)
    for r in cylinders:
        if r.get("true_radius"):
            ax.axhline(r["true_radius"], color="k", lw=0.6, ls="--")
    ax.set_ylabel("fitted radius (cm)")
    ax.set_title("radius of the cylinders", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    handles = dict(zip(*axes[1].get_legend_handles_labels()[::-1], strict=True))
    keys = ("this simulation", "thesis (robot)", "true S = 0.5 (cylinder)")
    place_legend(ax, [handles[k] for k in keys], [*keys[:2], "true value"])
    fig.supxlabel("fit weighting; biquadratic fits, 8 x 8 grid", fontsize=10)
    fig.suptitle(
        "Thesis tables 5-7: the ch. 5 experiment in simulation beside the thesis's robot",
        fontsize=10,
    )
    return save(plt, fig, path)[0]


def _surface_title(row):
    radius = row.get("true_radius")
    name = row["surface"].replace("_", " ")
    return f"{name} (S undefined)" if radius is None else f"{name}, radius {radius:g} cm"


def _pairs(ax, rows, key, err, thesis, thesis_err, by_surface=False):
    """Ours and the thesis's value (+- STD) side by side per weighting (and surface)."""
    kind = {"cylinder": "convex", "concave_cylinder": "concave"}
    names = [
        f"{r['weighting']}\n{kind[r['surface']]}" if by_surface else r["weighting"] for r in rows
    ]
    x = np.arange(len(rows))
    for shift, k, e, label, marker in (
        (-0.15, key, err, "this simulation", "o"),
        (0.15, thesis, thesis_err, "thesis (robot)", "s"),
    ):
        y = np.array([_value(r, k) for r in rows])
        yerr = None if e is None else np.nan_to_num([_value(r, e) for r in rows])
        ok = np.isfinite(y)
        ax.errorbar(
            x[ok] + shift, y[ok], yerr=None if yerr is None else yerr[ok], fmt=marker, ms=4,
            capsize=2, lw=1, label=label,
        )  # fmt: skip
    ax.set_xticks(x, names, fontsize=7.5 if by_surface else 8)
    ax.set_xlim(-0.6, len(rows) - 0.4)
