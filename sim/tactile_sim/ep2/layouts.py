"""Contact layouts for the EP2 test cases (``tactile_studies.ep2.cases``): where fingers touch.

Each layout gives in-plane positions ``xy`` (n, 2), a ``finger`` label per row
(rows in sweep order within each finger, as ``sweep.py`` and the thesis's
three-finger sweep, §4.1, fig. 24) and its nominal box.  ``place`` centres the
box on the origin and turns everything by ``angle`` (deg) about it, so a sweep
need not run along y.  Lengths are in the case's base unit.

``LAYOUTS`` maps a name to its function.  Parameters are keyword arguments;
``scatter`` draws from the trial's ``rng``, every other layout is fixed.
"""

import numpy as np


def sweep(xs=(0.0, 2.0, 4.0), length=4.0, stops=9, repeats=1, **_):
    """Fingers at x = ``xs`` sweeping y over ``length`` with ``stops`` stops, ``repeats``
    readings each (§5.1: 3 passes x 6 points x 2 samples = 36 contacts)."""
    xs = np.asarray(xs, float)
    ys = np.linspace(0.0, length, stops)
    x = np.repeat(xs, stops * repeats)
    y = np.tile(np.repeat(ys, repeats), xs.size)
    finger = np.repeat(np.arange(xs.size), stops * repeats)
    return np.column_stack([x, y]), finger


def line(length=4.0, n=27, **_):
    """One finger, one straight line: the curvature across it is not determined."""
    return sweep(xs=(0.0,), length=length, stops=n)


def grid(size=4.0, nx=6, ny=6, **_):
    """An nx x ny grid over a size x size square; each column is one finger."""
    return sweep(xs=np.linspace(0.0, size, nx), length=size, stops=ny)


def scatter(size=4.0, n=27, aspect=1.0, rng=None, **_):
    """n points uniform in a size x (aspect size) box, redrawn per trial; a finger each."""
    rng = np.random.default_rng(0) if rng is None else rng
    box = np.array([size, aspect * size])
    return rng.uniform(0.0, 1.0, (n, 2)) * box, np.arange(n), box


def cluster(size=4.0, n=27, spread=0.02, **_):
    """n - 1 contacts within ``spread`` x size of one corner, one at the opposite corner:
    the box is size x size, but its centre lies far from almost all the data."""
    k = int(np.ceil(np.sqrt(n - 1)))
    g = np.linspace(0.0, spread * size, k)
    gx, gy = (v.ravel()[: n - 1] for v in np.meshgrid(g, g, indexing="ij"))
    return np.vstack([np.column_stack([gx, gy]), [[size, size]]]), np.arange(n)


def duplicates(distinct=2, n=36, length=4.0, **_):
    """``distinct`` contacts on one line, each repeated until there are n rows."""
    ys = np.linspace(0.0, length, distinct)
    return np.column_stack([np.zeros(n), ys[np.arange(n) % distinct]]), np.arange(n) % distinct


LAYOUTS = {
    "sweep": sweep,
    "line": line,
    "grid": grid,
    "scatter": scatter,
    "cluster": cluster,
    "duplicates": duplicates,
}


def place(name, params, rng=None):
    """(xy, finger, corners, size) of layout ``name`` with ``params`` ((key, value) pairs).

    The box is centred on the origin and turned by ``angle``; ``corners`` (4, 2)
    are its corners (every contact lies within), ``size`` its larger side, the
    nominal patch size.
    """
    if name not in LAYOUTS:
        raise ValueError(f"unknown layout {name!r} (choose {', '.join(LAYOUTS)})")
    kw = dict(params)
    out = LAYOUTS[name](rng=rng, **kw)
    xy, finger = out[0], out[1]
    lo, hi = (np.zeros(2), out[2]) if len(out) > 2 else (xy.min(axis=0), xy.max(axis=0))
    half = 0.5 * (hi - lo)
    xy = xy - 0.5 * (lo + hi)
    corners = half * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    a = np.radians(kw.get("angle", 0.0))
    turn = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    return xy @ turn, finger, corners @ turn, float(2 * half.max())
