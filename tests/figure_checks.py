"""What a paper's reviewer checks on a figure, as code: units on every axis label, legends
that hide no data, readable fonts, tick labels that do not overprint, the thesis's figure
number.  Figures are caught as they are saved (``caught``), so any plotting code can be
checked without changing what it returns.
"""

import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.figure  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from tactile_studies.figures import covers_data  # noqa: E402

# A unit, in the last parenthesised group of a label: '(cm)', '(1e3 cm)', '(%)', '(rad,
# 1 sigma)', '(dimensionless)', '(length unit of R1)', '(1/cm)'.
UNIT = re.compile(
    r"\(([^()]*\b(dimensionless|rad|deg|ms|cm|mm|m|input unit|length unit)\b[^()]*|%|[^()]*1/"
    r"[^()]*)\)\s*$"
)
MIN_FONT = 7.0


def caught(mocker):
    """Spy on ``Figure.savefig``: returns a function giving the figures saved so far."""
    spy = mocker.spy(matplotlib.figure.Figure, "savefig")
    return lambda: [c.args[0] for c in spy.call_args_list]


def _render(fig):
    """A renderer with the figure laid out (a closed figure is re-attached to Agg)."""
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _plots(fig):
    """The data axes (not colour bars)."""
    return [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]


def _axes_of(ax):
    return [ax.xaxis, ax.yaxis] + ([ax.zaxis] if hasattr(ax, "zaxis") else [])


def label_of(fig, ax, axis):
    """An axis's label, else the shared label that stands for it (figure supxlabel, or the
    y label of a panel it shares y with)."""
    text = axis.get_label_text()
    if text:
        return text
    if axis is ax.xaxis and fig._supxlabel is not None:
        return fig._supxlabel.get_text()
    if axis is ax.yaxis:
        for other in ax.get_shared_y_axes().get_siblings(ax):
            if other.get_ylabel():
                return other.get_ylabel()
    if axis is ax.xaxis:
        for other in ax.get_shared_x_axes().get_siblings(ax):
            if other.get_xlabel():
                return other.get_xlabel()
    return ""


def categorical(axis):
    """An axis whose tick labels are names (e.g. weightings), not numbers: it has no unit."""
    texts = [t.get_text().replace("\u2212", "-") for t in axis.get_ticklabels() if t.get_text()]

    def number(text):
        try:
            float(text)
        except ValueError:
            return False
        return True

    return bool(texts) and not any(number(t.split("\n")[0]) for t in texts)


def unit_problems(fig):
    """Axis labels (x, y and z of every data axes, and colour bars) without a unit in
    parentheses."""
    out = []
    for bar in (ax for ax in fig.axes if ax.get_label() == "<colorbar>"):
        text = bar.get_ylabel() or bar.get_xlabel()
        if not UNIT.search(text.strip()):
            out.append(f"colour bar label {text!r} has no unit")
    for ax in _plots(fig):
        for axis in _axes_of(ax):
            text = label_of(fig, ax, axis)
            if not UNIT.search(text.strip()) and not categorical(axis):
                out.append(f"{axis.axis_name} label {text!r} has no unit")
    return out


def overprinted(fig):
    """Pairs of drawn tick labels on one axis whose boxes overlap."""
    renderer = _render(fig)
    out = []
    for ax in _plots(fig):
        for axis in _axes_of(ax):
            lo, hi = sorted(axis.get_view_interval())
            ticks = axis.get_major_ticks() + axis.get_minor_ticks()
            labels = [
                t.label1
                for t in ticks
                if lo <= t.get_loc() <= hi and t.label1.get_visible() and t.label1.get_text()
            ]
            boxes = [t.get_window_extent(renderer) for t in labels]
            out += [
                (axis.axis_name, labels[i].get_text(), labels[j].get_text())
                for i in range(len(boxes))
                for j in range(i + 1, len(boxes))
                if boxes[i].overlaps(boxes[j])
            ]
    return out


def legend_problems(fig):
    """Legends that could hide data or are hard to read: on a 2-D plot, one that covers a
    data point or lies over another axes (inside its own axes, in the data's empty corner,
    is where it belongs); on a 3-D view, one over any axes; entries in a small font."""
    renderer = _render(fig)
    out = []
    for ax in _plots(fig):
        legend = ax.get_legend()
        if legend is None:
            continue
        box = legend.get_window_extent(renderer)
        three_d = hasattr(ax, "zaxis")
        for other in _plots(fig):
            if (three_d or other is not ax) and box.overlaps(other.get_window_extent(renderer)):
                out.append(f"legend of {ax.get_title()!r} lies over an axes")
        if not three_d and covers_data(ax, box):
            out.append(f"legend of {ax.get_title()!r} covers data")
        small = [t.get_text() for t in legend.get_texts() if t.get_fontsize() < MIN_FONT]
        if small:
            out.append(f"legend entries {small} below {MIN_FONT} pt")
    return out


def titles(fig):
    """Every title text of the figure: suptitle and axes titles, joined."""
    parts = [fig._suptitle.get_text()] if fig._suptitle is not None else []
    return "\n".join(parts + [ax.get_title() for ax in fig.axes])


def paper_problems(fig):
    """Everything a reviewer would flag that can be checked mechanically."""
    return unit_problems(fig) + legend_problems(fig) + [f"overprint {p}" for p in overprinted(fig)]
