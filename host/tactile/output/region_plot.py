"""A PNG of one object's region map (``tactile.ep2.region_map.map_contacts``), in the style
of thesis fig. 50: each contact drawn in the colour of its region's shape index S, on the
same diverging scale as the S maps (convex red, saddle white, concave blue; a plane, which
has no S, grey), and the edges between regions as lines: creases (ridges, valleys) solid,
curvature jumps dashed.  The legend names each region (its label, S and contact count) and
each edge (its kind and dihedral angle); the axes name their length unit.

``plot_region_map`` takes the contacts, the ``RegionMap`` and a path, writes the PNG and
returns the path; matplotlib (the ``plot`` extra) is imported only inside it, on Agg.
"""

import numpy as np

from tactile.output import plots
from tactile.output.text import count

MAP_REF = "cf. thesis fig. 50, §6.2.4-6.2.5"
PLANE_GREY = "0.6"
EDGE_STYLE = {"ridge": ("k", "-"), "valley": ("k", "-"), "curvature jump": ("0.25", "--")}
NEAR_EDGE = 0.1  # contacts this share of the span from an edge's line set its drawn length
SIZE = 14


def region_colours(regions, cmap):
    """(RGBA per region in order): S on [-1, 1] through ``cmap``, grey where S is None."""
    from matplotlib.colors import Normalize, to_rgba

    norm = Normalize(-1.0, 1.0)
    return [to_rgba(PLANE_GREY) if r.S is None else cmap(norm(r.S)) for r in regions]


def edge_segment(edge, points, regions, span):
    """(2, 3) ends of an edge's line as drawn: along its direction, over the contacts of
    its two regions that lie within ``NEAR_EDGE`` x ``span`` of the line; None for an edge
    without a direction (a curvature jump seen at one point)."""
    if edge.direction is None:
        return None
    p, d = np.asarray(edge.point, float), np.asarray(edge.direction, float)
    rows = np.concatenate([regions[i].contacts for i in edge.regions]).astype(int)
    off = points[rows] - p
    t = off @ d
    near = np.linalg.norm(off - np.outer(t, d), axis=1) <= NEAR_EDGE * span
    if not near.any():
        return None
    return np.stack([p + t[near].min() * d, p + t[near].max() * d])


def plot_region_map(points, region_map, path, title=None, unit=None):
    """Contacts coloured by their region's S, and the edges between regions (module
    docstring).  ``points`` (n, 3) the contacts ``region_map`` was made from."""
    plt = plots.require_matplotlib()
    pts = np.asarray(points, float)
    regions = sorted(region_map.regions, key=lambda r: r.id)
    span = plots._span(pts)
    view = plots._View(pts, span)
    cmap = plt.get_cmap(plots.S_CMAP)
    colours = region_colours(regions, cmap)
    fig = plt.figure(figsize=(7.0, 5.4))
    ax = fig.add_subplot(projection="3d")
    for r, colour in zip(regions, colours, strict=True):
        p = view(pts[np.asarray(r.contacts, int)])
        s = "no S" if r.S is None else f"S {r.S:.2f}"
        name = f"region {r.id}: {r.shape.replace('_', ' ')}, {s}, {len(r.contacts)} contacts"
        ax.scatter(*p.T, color=colour, s=SIZE, depthshade=False, edgecolors="k",
                   linewidths=0.2, label=plots.plain_text(name))  # fmt: skip
    for e in region_map.edges:
        seg = edge_segment(e, pts, regions, span)
        colour, style = EDGE_STYLE.get(e.kind, ("k", ":"))
        what = e.kind if e.dihedral_interval is None else f"{e.kind} {e.dihedral_deg:.1f} deg"
        name = f"edge {e.regions[0]}-{e.regions[1]}: {what}"
        if seg is None:
            ax.scatter(*view(np.asarray(e.point, float)[None]).T, color=colour, marker="x",
                       s=60, depthshade=False, label=name)  # fmt: skip
        else:
            ax.plot(*view(seg).T, color=colour, linestyle=style, linewidth=2.0, label=name)
    plots._equal_3d(ax, view(pts), view.length(0.05 * span))
    labels = view.labels("xyz", unit)
    ax.set(**dict(zip(("xlabel", "ylabel", "zlabel"), labels, strict=True)))
    mappable = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(-1.0, 1.0))
    fig.colorbar(mappable, ax=ax, orientation="horizontal", shrink=0.6, pad=0.08,
                 label="shape index S (dimensionless; grey: a plane, no S)")  # fmt: skip
    ax.legend(**plots.LEGEND)
    first = (
        plots.plain_text(title)
        if title
        else (
            f"Region map: {count(len(regions), 'region')}, {count(len(region_map.edges), 'edge')}"
        )
    )
    ax.set_title(f"{first}\n({MAP_REF})", fontsize=10)
    plots._thin_ticks(fig, ax)
    return plots.save(plt, fig, path)
