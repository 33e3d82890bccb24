"""What every study figure shares: legends that hide no data, and saving whole.

Legends that hide no data: in the plot's emptiest corner when it has one, else in a row
just above the axes (the thesis's study figures are often full from edge to edge).

``place_legend(ax, *handles_labels, **kw)`` is ``ax.legend`` with that rule; ``covers_data``
is the rule (a point of a line or scatter of ``ax`` inside the legend's box).

``save(plt, fig, path)`` writes a figure whole (``tactile.files.writing.atomic_write``), its
format the name's, at ``DPI``, and closes it."""

import numpy as np

from tactile.output import plots

STYLE = dict(fontsize=8)
DPI = 110


def place_legend(ax, *args, **kw):
    """The legend of ``ax`` inside it where no data point lies under it, else above it."""
    legend = ax.legend(*args, loc="best", framealpha=0.9, **STYLE, **kw)
    ax.figure.canvas.draw()  # (where 'best' put it is known once drawn)
    if not covers_data(ax, legend.get_window_extent()):
        return legend
    legend.remove()
    n = len(legend.get_texts())
    return ax.legend(*args, loc="lower left", bbox_to_anchor=(0.0, 1.02, 1.0, 0.1),
                     mode="expand", ncol=min(n, 4), borderaxespad=0.0, **STYLE, **kw)  # fmt: skip


def covers_data(ax, box):
    """Whether ``box`` (display coordinates) holds a point of a line or scatter of ``ax``."""
    points = [line.get_transform().transform(line.get_xydata()) for line in ax.lines]
    for c in ax.collections:
        offsets = np.asarray(c.get_offsets())
        if len(offsets):
            points.append(c.get_offset_transform().transform(offsets))
    for xy in points:
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        x, y = xy[:, 0], xy[:, 1]
        if ((x > box.x0) & (x < box.x1) & (y > box.y0) & (y < box.y1)).any():
            return True
    return False


def save(plt, fig, path):
    """Write ``fig`` to ``path`` whole (its format the name's), close it: ``[path]``."""
    return [str(plots.save(plt, fig, path, dpi=DPI, tight=False))]
