"""PNG figures for the EP1 studies (figs. 16, 18, 20, 21).  Imports matplotlib when called."""

import numpy as np

__all__ = ["plot_noise", "plot_paraboloid", "plot_resolution", "plot_arclength", "plot_optimal"]


def _figure(n):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.6), squeeze=False, sharey=True)
    return plt, fig, axes[0]


def _panels(rows, panel_key, line_key, x_key, y_key, title, xlabel, path, xlog=True, extra=None):
    panels = sorted({r[panel_key] for r in rows})
    plt, fig, axes = _figure(len(panels))
    for ax, pv in zip(axes, panels, strict=True):
        sub = [r for r in rows if r[panel_key] == pv]
        for lv in sorted({r[line_key] for r in sub}):
            pts = sorted((r[x_key], r[y_key]) for r in sub if r[line_key] == lv)
            x, y = np.array(pts).T
            ax.plot(x, 100 * np.maximum(y, 1e-14), marker="o", ms=3, label=f"{line_key}={lv:g}")
        ax.set_xscale("log" if xlog else "linear")
        ax.set_yscale("log")
        ax.set_title(f"{title} {panel_key}={pv:g}", fontsize=9)
        ax.set_xlabel(xlabel)
        ax.grid(True, which="both", alpha=0.3)
        if extra:
            extra(ax)
    axes[0].set_ylabel("relative curvature error (%)")
    axes[-1].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_noise(rows, path):
    """Fig. 16: error vs RCR, one panel per dtheta, one line per angle noise."""
    _panels(rows, "dtheta", "noise", "rcr", "mean_rel_error", "fig. 16", "RCR = R2/R1", path)


def plot_paraboloid(rows, path):
    """Fig. 18: error along u vs local radius, one panel per dtheta, one line per noise."""
    _panels(
        rows, "dtheta", "noise", "radius_u", "mean_rel_error_u", "fig. 18", "radius along u", path
    )


def plot_resolution(rows, path):
    """Fig. 20: one row of panels per sensor model; error vs RCR per resolution."""
    for sensor in sorted({r["sensor"] for r in rows}):
        sub = [r for r in rows if r["sensor"] == sensor]
        _panels(
            sub,
            "dtheta",
            "resolution",
            "rcr",
            "mean_rel_error",
            f"fig. 20 ({sensor})",
            "RCR",
            str(path).replace(".png", f"_{sensor}.png"),
            extra=lambda ax: ax.axhline(25, color="k", lw=0.6, ls=":"),
        )


def plot_arclength(rows, path):
    """Fig. 21: arc length vs RCR with the thesis's 0.008 and 125 marks."""
    plt, fig, (ax,) = _figure(1)
    cf = [r for r in rows if r.get("source") != "ode"]
    ode = [r for r in rows if r.get("source") == "ode"]
    ax.plot([r["rcr"] for r in cf], [r["ds"] for r in cf], label="closed form (eq. 38)")
    ax.plot([r["rcr"] for r in ode], [r["ds"] for r in ode], "o", label="ODE (eqs. 24-28)")
    for x in (0.008, 125):
        ax.axvline(x, ls="--", color="k", lw=0.7)
    ax.set_xscale("log")
    ax.set_xlabel("RCR = R2/R1")
    ax.set_ylabel("arc length on finger")
    ax.set_title("fig. 21: dtheta = 90 deg")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_optimal(rows, path):
    """Expected error vs radius for the best dtheta per radius and a few fixed dthetas."""
    plt, fig, (ax,) = _figure(1)
    radii = np.array([r["radius"] for r in rows])
    keys = [k for k in rows[0] if k.startswith("err_dtheta_")]
    for k in keys[:: max(1, len(keys) // 5)]:
        ax.plot(radii, [100 * r[k] for r in rows], lw=0.8, label=k[4:])
    ax.plot(radii, [100 * r["oracle_error"] for r in rows], "k:", lw=1.5, label="oracle dtheta")
    ax.plot(radii, [100 * r["adaptive_error"] for r in rows], "k", lw=2, label="adaptive dtheta")
    ax.axhline(25, color="k", lw=0.6, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("sphere radius (R1 = 1)")
    ax.set_ylabel("mean relative error (%)")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
