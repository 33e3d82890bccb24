"""PNG figures of an EP2 patch: contacts and normals, the fitted patch with its control
mesh (thesis figs. 39 ii, 40, 43, 47) and the S and C maps over the grid (fig. 50).

Functions take arrays or a ``PatchResult`` (``tactile.ep2.analyze_patch``) and a path,
write the PNG and return the path.  matplotlib (the ``plot`` extra) is imported only
inside them, with the Agg backend; without it they raise ``tactile.errors.MissingExtra``.

Every figure has a plain title naming the thesis figure it reproduces, draws geometry to
equal scale, puts its legend outside the axes (where it hides no data), gives a colour bar
at least a span relative to its values (round-off in a constant field is drawn constant)
and labels each axis with its unit: ``unit`` is the length
unit of the contacts (``None``: "input unit", the CSV contract allows any).  ``group``
names what the ``finger`` labels count: fingers (the simulator's three-finger sweep) or
passes (the ch. 5 rig moves one finger in passes).
"""

import functools
import os

import numpy as np

from tactile.ep2 import patch_input
from tactile.ep2.geometry import unit_normals
from tactile.errors import InputError, pyplot
from tactile.files.writing import atomic_write
from tactile.output.text import printable

__all__ = [
    "colour_limits",
    "map_grids",
    "plot_contacts",
    "plot_maps",
    "plot_patch",
    "require_matplotlib",
]

DPI = 100
S_CMAP = "RdBu_r"  # diverging: convex (S > 0) red, saddle white, concave blue
C_CMAP = "viridis"
NORMAL_LENGTH = 0.15  # arrow length as a fraction of the contacts' largest extent
SURFACE_SAMPLES = 25  # per direction, for drawing the fitted surface
SMALLEST, LARGEST = 1e-4, 1e5  # spreads drawn in the input unit; others in a power of ten
FAR = 1e12  # a box whose middle is this many spreads from 0 is drawn about that middle
TICK_BINS = (6, 4, 3, 2, 1)  # tick intervals per axis, tried until no labels overprint
NICE = (1, 2, 2.5, 5, 10)  # tick steps (times a power of ten)
LEGEND = dict(fontsize=8, loc="upper left", bbox_to_anchor=(1.04, 1.0), borderaxespad=0.0)
PATCH_FIGURE = {"plane": "fig. 40", "cylinder": "fig. 43", "concave_cylinder": "fig. 47"}
CONTACTS_REF = "cf. thesis figs. 39 ii, 42 ii, 46 ii"
MAPS_REF = "cf. thesis fig. 50"
MIN_SPAN = 1e-3  # a colour bar spans at least this times max(|mean value|, 1)
ORDER_NAME = {2: "biquadratic", 3: "bicubic", 4: "biquartic"}


def require_matplotlib():
    """Return ``matplotlib.pyplot`` on the Agg backend, or raise ``MissingExtra``."""
    return pyplot()


def plain_text(text):
    """``text`` from a file, as a label drawn as written: non-printable characters escaped
    as on the terminal (``tactile.output.text``), characters the font has no glyph for as
    ``\\uXXXX`` (matplotlib would warn and draw a box), ``$`` not starting mathtext."""
    have = _glyphs()
    text = printable(str(text))
    text = "".join(c if ord(c) in have else c.encode("unicode_escape").decode() for c in text)
    return text.replace("$", r"\$")


@functools.cache
def _glyphs():
    """The code points the default font draws (printable ASCII if that cannot be told)."""
    try:
        from matplotlib import font_manager, ft2font

        path = font_manager.findfont(font_manager.FontProperties())
        return frozenset(ft2font.FT2Font(path).get_charmap())
    except Exception:  # any failure here only makes labels more escaped
        return frozenset(range(0x20, 0x7F))


def _contacts(points, normals):
    """Validated (n, 3) points and unit normals."""
    pts = np.asarray(points, float)
    nrm = np.asarray(normals, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or nrm.shape != pts.shape or not len(pts):
        raise InputError(f"points and normals must both be (n, 3); got {pts.shape}, {nrm.shape}")
    ok = np.all(np.isfinite(pts)) and np.all(np.isfinite(nrm))
    if not (ok and np.all(np.max(np.abs(nrm), axis=1) > 0)):
        raise InputError("points and normals must be finite, normals of non-zero length")
    problem = patch_input.spread_problem(pts)
    if problem is not None:
        raise InputError(f"contact {problem[0]}: {problem[2]}")
    return pts, unit_normals(nrm)


def _span(points):
    """Largest side of the points' box (at least 1e-300), without overflow."""
    return float(max(2.0 * patch_input.box(points)[1].max(), patch_input.MIN_SPREAD))


class _View:
    """What is drawn: (p - origin) / unit.  Coordinates far from unit size are drawn in a
    power-of-ten unit, and a box whose middle is over ``FAR`` spreads from 0 about that
    middle; both are named on the axes.  matplotlib's 3-D projection and shading square
    coordinates, which leave the float range beyond ~1e+-154."""

    def __init__(self, points, span):
        self.e = int(np.floor(np.log10(span)))
        self.unit = 1.0 if SMALLEST <= span <= LARGEST else 10.0**self.e
        middle = patch_input.box(np.asarray(points, float))[0]
        self.origin = np.where(np.abs(middle) > FAR * span, middle, 0.0)

    def __call__(self, p):
        return (np.asarray(p, float) - self.origin) / self.unit

    def length(self, v):
        return np.asarray(v, float) / self.unit

    def labels(self, names, unit=None):
        """Axis labels with the unit, e.g. 'x (cm)', 'x (1e-6 cm)', 'x - 3e+20 (m)'."""
        scale = f"1e{self.e} " if self.unit != 1.0 else ""
        out = []
        for name, o in zip(names, self.origin, strict=True):
            text = f"{name} - {float(o)!r}" if o else name
            out.append(f"{text} ({scale}{unit_name(unit)})")
        return out


def unit_name(unit):
    """The length unit as drawn: ``unit``, or 'input unit' when the input does not say."""
    return unit or "input unit"


def _equal_3d(ax, points, pad):
    """Equal scale on x, y and z (so normals look normal), each range padded by ``pad``."""
    lo = points.min(axis=0) - pad
    hi = points.max(axis=0) + pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo))


def _thin_ticks(fig, ax):
    """As many ticks per axis as fit without their labels overprinting: a short side of
    the equal-scale box (a rig's sweep seen edge-on) gets fewer, down to one."""
    from matplotlib.ticker import MaxNLocator

    ax.tick_params(labelsize=8)
    axes = (ax.xaxis, ax.yaxis, ax.zaxis)
    for axis in axes:
        axis.set_major_locator(MaxNLocator(nbins=TICK_BINS[0], steps=NICE, min_n_ticks=2))
    step = dict.fromkeys(axes, 0)
    for _ in TICK_BINS:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        crowded = [a for a in axes if step[a] + 1 < len(TICK_BINS) and _overprinted(a, renderer)]
        if not crowded:
            return
        for axis in crowded:
            step[axis] += 1
            n = TICK_BINS[step[axis]]
            axis.set_major_locator(MaxNLocator(nbins=n, steps=NICE, min_n_ticks=min(n, 2)))


def _overprinted(axis, renderer):
    """True if two drawn tick labels of ``axis`` overlap."""
    lo, hi = sorted(axis.get_view_interval())
    boxes = [
        t.label1.get_window_extent(renderer)
        for t in axis.get_major_ticks()
        if lo <= t.get_loc() <= hi and t.label1.get_visible() and t.label1.get_text()
    ]
    return any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1 :])


def _contacts_3d(ax, points, normals, finger, length, group="finger"):
    """Contacts as dots (one colour per finger or pass) with their normals as arrows."""
    groups = [(None, np.arange(len(points)))]
    if finger is not None:
        labels = [str(f) for f in finger]
        groups = [
            (f, np.array([i for i, g in enumerate(labels) if g == f]))
            for f in dict.fromkeys(labels)
        ]
    for n, (label, rows) in enumerate(groups):
        colour = f"C{n % 10}"
        p, v = points[rows], normals[rows] * length
        name = label and plain_text(f"{group} {label}")
        ax.scatter(*p.T, color=colour, s=10, depthshade=False, label=name)
        ax.quiver(*p.T, *v.T, color=colour, linewidth=0.8, arrow_length_ratio=0.25)


def save(plt, fig, path, dpi=DPI, tight=True):
    """Write ``fig`` to ``path`` whole (``atomic_write``; the format the name's, as
    ``savefig(path)`` takes it), trimmed to its drawing unless ``tight`` is false; close it."""
    trim = {"bbox_inches": "tight", "pad_inches": 0.15} if tight else {}
    try:
        with atomic_write(path) as fh:
            fig.savefig(fh, format=image_format(path), dpi=dpi, **trim)
    finally:
        plt.close(fig)
    return path


def image_format(path):
    """The image format ``path``'s extension names (png without one, as matplotlib)."""
    return os.path.splitext(os.fspath(path))[1][1:].lower() or "png"


def plot_contacts(points, normals, path, finger=None, title=None, unit=None, group="finger"):
    """Contact points with their normals in the input frame (figs. 39 ii, 42 ii, 46 ii)."""
    plt = require_matplotlib()
    pts, nrm = _contacts(points, normals)
    span = _span(pts)
    view = _View(pts, span)
    pts, length = view(pts), view.length(NORMAL_LENGTH * span)
    fig = plt.figure(figsize=(5.5, 5.0))
    ax = fig.add_subplot(projection="3d")
    _contacts_3d(ax, pts, nrm, finger, length, group)
    _equal_3d(ax, np.vstack([pts, pts + nrm * length]), view.length(0.05 * span))
    if finger is not None:
        ax.legend(**LEGEND)
    ax.set(**dict(zip(("xlabel", "ylabel", "zlabel"), view.labels("xyz", unit), strict=True)))
    first = plain_text(title) if title else f"{len(pts)} contacts and normals"
    ax.set_title(f"{first}\n({CONTACTS_REF})", fontsize=10)
    _thin_ticks(fig, ax)
    return save(plt, fig, path)


def plot_patch(result, points, normals, path, finger=None, title=None, unit=None, group="finger"):
    """The fitted patch (with its control mesh for the spline) and the contacts (figs. 40, 43, 47).

    Drawn in the patch frame (z = mean outward normal, §5.1.2), to equal scale
    on all axes, as the thesis draws its fits in the fitting frame.
    """
    plt = require_matplotlib()
    pts, nrm = _contacts(points, normals)
    pts, nrm = result.frame.to_patch(pts), result.frame.to_patch_dirs(nrm)
    net = result.control_net()  # None for the jet: it has no control points
    x0, x1, y0, y1 = result.domain_box()
    gx, gy = np.meshgrid(
        np.linspace(x0, x1, SURFACE_SAMPLES), np.linspace(y0, y1, SURFACE_SAMPLES), indexing="ij"
    )
    gz = result.surface(np.column_stack([gx.ravel(), gy.ravel()])).reshape(gx.shape)
    span = _span(pts)
    view = _View(pts, span)
    pts, length = view(pts), view.length(NORMAL_LENGTH * span)
    gx, gy, gz = np.moveaxis(view(np.stack([gx, gy, gz], axis=-1)), -1, 0)
    net = None if net is None else view(net)

    fig = plt.figure(figsize=(6.0, 5.2))
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(gx, gy, gz, color="0.75", alpha=0.55, linewidth=0, shade=True)
    surface = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    every = [pts, pts + nrm * length, surface]
    if net is not None:
        ax.plot_wireframe(*np.moveaxis(net, -1, 0), color="k", linewidth=0.9, label="control mesh")
        ax.scatter(*net.reshape(-1, 3).T, color="k", s=14, marker="s", depthshade=False)
        every.append(net.reshape(-1, 3))
    _contacts_3d(ax, pts, nrm, finger, length, group)
    every = np.vstack(every)
    _equal_3d(ax, every, view.length(0.05 * span))
    names = ("patch x", "patch y", "patch z")
    ax.set(**dict(zip(("xlabel", "ylabel", "zlabel"), view.labels(names, unit), strict=True)))
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**LEGEND)
    first = plain_text(title) if title else f"Fitted patch: {_summary(result, unit)}"
    ax.set_title(f"{first}\n({patch_reference(result)})", fontsize=10)
    _thin_ticks(fig, ax)
    return save(plt, fig, path)


def patch_reference(result):
    """The thesis figure a patch figure corresponds to, by the fit's label."""
    number = PATCH_FIGURE.get(result.shape)
    return f"cf. thesis {number}" if number else "cf. thesis figs. 40, 43, 47"


def fit_name(result):
    """The fit in plain words: 'biquadratic B-spline', 'bicubic B-spline', 'local jet'."""
    if result.method == "spline":
        return f"{ORDER_NAME.get(result.order, f'degree {result.order}')} B-spline"
    return "local jet"


def _summary(result, unit=None):
    """'cylinder, S 0.501, radius 6.98 cm (biquadratic B-spline)', at the patch centre."""
    text = result.shape.replace("_", " ")
    if result.S is not None:
        text += f", S {result.S:.3f}"
    if result.radius is not None:
        text += f", radius {result.radius:.3g} {unit_name(unit)}"
    return f"{text} ({fit_name(result)})"


def colour_limits(values):
    """(vmin, vmax) for a colour bar of ``values`` (NaN ignored): their range, widened about
    its middle to at least ``MIN_SPAN`` x max(|mean|, 1) so that round-off in a constant
    field (C spanning 1.5184-1.5197) is not stretched over the whole colour scale."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not v.size:
        return None, None
    lo, hi = float(v.min()), float(v.max())
    least = MIN_SPAN * max(abs(float(v.mean())), 1.0)
    if hi - lo >= least:
        return lo, hi
    middle = 0.5 * (lo + hi)
    return middle - 0.5 * least, middle + 0.5 * least


def map_grids(result):
    """The N x N grid maps of ``result`` (analysed with ``maps=True``) as (N, N) arrays.

    Returns a dict with ``x``, ``y`` (patch frame, input units), ``S`` and ``C``
    (None for a plane, whose S and C are not computed, §4.8.2), x index first.
    """
    maps = result.maps
    if not maps:
        raise ValueError("analyze_patch(..., maps=True) is needed for the S and C maps")
    n = int(round(np.sqrt(maps["x"].size)))
    out = {k: np.reshape(maps[k], (n, n)) for k in ("x", "y")}
    for k in ("S", "C"):
        out[k] = np.reshape(maps[k], (n, n)) if k in maps else None
    return out


def plot_maps(result, path, points=None, title=None, unit=None):
    """S (left, on [-1, 1], diverging colours) and C (right) over the analysis grid (fig. 50).

    ``result`` needs ``maps=True``.  ``points`` (input frame), if given, are
    drawn as dots at their patch-frame (x, y).  For a plane the panels say why
    they are empty.  C = (2/pi) ln R depends on the length unit (R is in 1/unit).
    """
    plt = require_matplotlib()
    grids = map_grids(result)
    flat = np.column_stack([grids["x"].ravel(), grids["y"].ravel(), np.zeros(grids["x"].size)])
    view = _View(flat, _span(flat))
    x, y = (v.reshape(grids["x"].shape) for v in view(flat)[:, :2].T)
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.4), layout="constrained")
    panels = (
        ("S", "shape index S (dimensionless)", dict(cmap=S_CMAP, vmin=-1.0, vmax=1.0)),
        ("C", f"curvedness C = (2/\u03c0) ln R (R in 1/{unit_name(unit)})", dict(cmap=C_CMAP)),
    )
    xy = None if points is None else view(result.frame.to_patch(np.asarray(points, float)))
    for ax, (key, label, style) in zip(axes, panels, strict=True):
        values = grids[key]
        name = label.rsplit(" (", 1)[0]
        if values is None:  # said in the title: a note inside would cover the contacts
            name = f"plane: {key} not computed\n(curvedness below what the data resolve)"
            hx, hy = (0.5 * np.ptp(v) / (v.shape[0] - 1) for v in (x, y))
            ax.set(xlim=(x.min() - hx, x.max() + hx), ylim=(y.min() - hy, y.max() + hy))
        else:
            if "vmin" not in style:
                style["vmin"], style["vmax"] = colour_limits(values)
            mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(values), shading="nearest", **style)
            fig.colorbar(mesh, ax=ax, label=label)
        if xy is not None:
            ax.plot(xy[:, 0], xy[:, 1], "k.", ms=3, label="contacts")
        ax.set_aspect("equal")
        xlabel, ylabel, _ = view.labels(("patch x", "patch y", ""), unit)
        ax.set_title(name, fontsize=10)
        ax.set(xlabel=xlabel, ylabel=ylabel)
    n = x.shape[0]
    first = plain_text(title) if title else f"S and C on the {n}x{n} grid: {_summary(result, unit)}"
    dots = "" if xy is None else "; dots: contacts"
    fig.suptitle(f"{first}\n({MAPS_REF}{dots})", fontsize=10)
    return save(plt, fig, path)


def log_ticks(axis):
    """Labels only at major ticks; an axis spanning under two decades gets 1, 2, 5 per
    decade as plain numbers (matplotlib would label every minor tick, overprinting)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    lo, hi = sorted(axis.get_view_interval())
    if lo > 0 and hi / lo < 100:
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())
