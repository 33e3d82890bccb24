"""PNG figures for the EP1 studies: thesis figs. 16, 18, 20, 21 and the dtheta choice.

Lengths are in the unit of the fingertip radius R1 (the thesis's "units", R1 = 1 by
default), angles in rad and errors in % (truncated at 100 % as in fig. 20; an error
below ``FLOOR`` % is drawn at ``FLOOR``, so exact results stay on a log axis).  Each
function writes its PNG(s) and returns the list of paths written; matplotlib (Agg) is
imported when one is called.
"""

import numpy as np

from tactile.errors import pyplot
from tactile.output.plots import log_ticks
from tactile_studies.figures import place_legend, save

__all__ = ["plot_noise", "plot_paraboloid", "plot_resolution", "plot_arclength", "plot_optimal"]

FLOOR = 1e-12  # % : smallest error drawn
ERROR_LABEL = "relative curvature error (%)"
LENGTH = "length unit of R1"
FLOOR_NOTE = f"(errors truncated at 100 %; below {FLOOR:g} % drawn at {FLOOR:g} %)"


def _figure(n, width=3.6):
    plt = pyplot()

    fig, axes = plt.subplots(
        1, n, figsize=(width * n + 1.6, 3.5), squeeze=False, sharey=True, layout="constrained"
    )
    return plt, fig, axes[0]


def _percent(y):
    return 100 * np.maximum(np.asarray(y, float), FLOOR / 100)


def _lines(ax, rows, line_key, x_key, y_key, fmt):
    """One line per value of ``line_key``, its points sorted by the x variable."""
    for lv in sorted({r[line_key] for r in rows}):
        pts = sorted((r[x_key], r[y_key]) for r in rows if r[line_key] == lv)
        x, y = np.array(pts).T
        ax.plot(x, _percent(y), marker="o", ms=3, lw=1.2, label=fmt(lv))


def _angle(rad):
    """'0.25 rad', or '\u03c0/2 rad' for the thesis's quarter turn."""
    return "\u03c0/2 rad" if np.isclose(rad, np.pi / 2) else f"{rad:.4g} rad"


def _panels(rows, line_key, x_key, y_key, xlabel, legend_title, fmt, title, extra=None):
    """One panel per dtheta (log-log), one line per ``line_key``; returns (plt, fig)."""
    panels = sorted({r["dtheta"] for r in rows})
    plt, fig, axes = _figure(len(panels))
    for ax, dth in zip(axes, panels, strict=True):
        _lines(ax, [r for r in rows if r["dtheta"] == dth], line_key, x_key, y_key, fmt)
        ax.set(xscale="log", yscale="log")
        ax.set_title(f"\u0394\u03b8 = {_angle(dth)}", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        log_ticks(ax.xaxis)
        log_ticks(ax.yaxis)
        if extra:
            extra(ax)
    axes[0].set_ylabel(ERROR_LABEL)
    fig.supxlabel(xlabel, fontsize=10)
    place_legend(axes[-1], title=legend_title, title_fontsize=8)
    fig.suptitle(f"{title}\n{FLOOR_NOTE}", fontsize=10)
    return plt, fig


def plot_noise(rows, path):
    """Fig. 16: error vs RCR, one panel per dtheta, one line per angle noise."""
    plt, fig = _panels(
        rows,
        "noise",
        "rcr",
        "mean_rel_error",
        "RCR = R2/R1 (dimensionless)",
        "noise in \u0394\u03b8\n(rad, 1 sigma)",
        lambda v: f"{v:g}",
        "Thesis fig. 16: EP1 on spheres, exact contact sensor, noise in \u0394\u03b8",
    )
    return save(plt, fig, path)


def plot_paraboloid(rows, path):
    """Fig. 18: error along u vs the paraboloid's C (eq. 36), one panel per dtheta, one line
    per noise.  The local radius along u (table 4) is not monotonic in C (C = 0.1 and 1 give
    5.30 and 5.61), so the lines run along C and the top axis names each C's radius."""
    plt, fig = _panels(
        rows,
        "noise",
        "C",
        "mean_rel_error_u",
        f"paraboloid C, z = -C(x\u00b2 + y\u00b2) (1/{LENGTH})",
        "noise in \u0394\u03b8\n(rad, 1 sigma)",
        lambda v: f"{v:g}",
        "Thesis fig. 18: EP1 on paraboloids at (u, v) = (1.0, 0.1), error along u",
        extra=lambda ax: _radius_axis(ax, rows),
    )
    return save(plt, fig, path)


def _radius_axis(ax, rows):
    """A top axis at the C values, labelled with the radius along u at (1.0, 0.1)."""
    radius = dict(sorted({(r["C"], r["radius_u"]) for r in rows}))
    top = ax.secondary_xaxis("top")
    top.set_xticks(list(radius), [f"{v:.3g}" for v in radius.values()], fontsize=7)
    top.minorticks_off()
    top.set_xlabel(f"radius along u ({LENGTH})", fontsize=8)
    ax.set_xticks(list(radius), [f"{c:g}" for c in radius], fontsize=8)
    ax.minorticks_off()


def plot_resolution(rows, path):
    """Fig. 20: one PNG per sensor model (PATH_SENSOR.png); error vs RCR per resolution."""
    written = []
    stem = str(path)[:-4] if str(path).endswith(".png") else str(path)
    for sensor in sorted({r["sensor"] for r in rows}):
        plt, fig = _panels(
            [r for r in rows if r["sensor"] == sensor],
            "resolution",
            "rcr",
            "mean_rel_error",
            "RCR = R2/R1 (dimensionless)",
            f"contact-sensor\nresolution\n({LENGTH})",
            lambda v: f"{v:g}",
            f"Thesis fig. 20: EP1 on spheres, no angle noise, '{sensor}' contact-sensor model",
            extra=_quarter_line,
        )
        written += save(plt, fig, f"{stem}_{sensor}.png")
    return written


def _quarter_line(ax):
    ax.axhline(25, color="0.4", lw=0.8, ls="-.", label="25 % (\u00a73.3.3)")


def plot_arclength(rows, path):
    """Fig. 21: arc length vs RCR with the thesis's 0.008 and 125 marks."""
    plt, fig, (ax,) = _figure(1, width=4.4)
    cf = sorted((r["rcr"], r["ds"]) for r in rows if r.get("source") != "ode")
    ode = [r for r in rows if r.get("source") == "ode"]
    ax.plot(*np.array(cf).T, label="closed form (eq. 38)")
    ax.plot([r["rcr"] for r in ode], [r["ds"] for r in ode], "o", label="ODE (eqs. 24-28)")
    for i, x in enumerate((0.008, 125)):
        ax.axvline(x, ls="--", color="k", lw=0.7, label="RCR 0.008 and 125 (\u00a73.3.3)" * (not i))
    ax.set_xscale("log")
    log_ticks(ax.xaxis)
    ax.set(xlabel="RCR = R2/R1 (dimensionless)", ylabel=f"\u0394s on the finger ({LENGTH})")
    ax.grid(True, alpha=0.3)
    place_legend(ax)
    fig.suptitle(
        "Thesis fig. 21: \u0394s for \u0394\u03b8 = 90\u00b0 (\u03c0/2 rad) on spheres", fontsize=10
    )
    return save(plt, fig, path)


def plot_optimal(rows, path, setup=""):
    """Beyond the thesis: error vs radius for the adaptive and the best (oracle) dtheta per
    radius and a few fixed dthetas.  ``setup`` (e.g. the sensor) goes into the title."""
    plt, fig, (ax,) = _figure(1, width=5.0)
    radii = np.array([r["radius"] for r in rows])
    order = np.argsort(radii)
    keys = [k for k in rows[0] if k.startswith("err_dtheta_")]
    for k in keys[:: max(1, len(keys) // 5)]:
        err = np.array([r[k] for r in rows])
        ax.plot(radii[order], _percent(err[order]), lw=0.8, label=f"\u0394\u03b8 = {k[11:]} rad")
    for key, style, label in (
        ("oracle_error", dict(color="k", ls=":", lw=1.5), "best \u0394\u03b8 per true radius"),
        ("adaptive_error", dict(color="k", lw=2), "adaptive \u0394\u03b8 (two-stage)"),
    ):
        err = np.array([r[key] for r in rows])
        ax.plot(radii[order], _percent(err[order]), label=label, **style)
    _quarter_line(ax)
    ax.set(xscale="log", yscale="log", ylabel=ERROR_LABEL)
    log_ticks(ax.xaxis)
    log_ticks(ax.yaxis)
    ax.set_xlabel(f"sphere radius R2 ({LENGTH})")
    ax.grid(True, alpha=0.3)
    place_legend(ax)
    title = "Beyond the thesis: EP1 with \u0394\u03b8 chosen per estimate"
    fig.suptitle(title + (f"\n{setup}" if setup else ""), fontsize=10)
    return save(plt, fig, path)
