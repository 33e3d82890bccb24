"""Where the fingers touch, for ``families``: in-plane (u, v) layouts of unit size.

Every layout is returned as (uv (n, 2), finger (n,)) with its bounding box's larger side 1
and the box's middle at the origin, so scaling by the patch size L gives a patch of size L
centred on the chosen surface point.  Kinds (``KINDS``):

- ``sweep``: 2-4 parallel finger lines, 5-12 stops each, uneven spacing between lines and
  along them, in a random direction; one in three has one line turned by 5-25 deg.
- ``grid``: 3 x 3 to 6 x 6, jittered by up to 15 % of a cell, aspect 0.5-1, turned.
- ``scatter``: 10-40 points uniform in a box of aspect 0.5-1, turned.
- ``small``: 6-9 contacts, a scatter or 2-3 short lines (2-4 stops each).
"""

import numpy as np

KINDS = ("sweep", "grid", "scatter", "small")


def _turn(uv, angle):
    c, s = np.cos(angle), np.sin(angle)
    return uv @ np.array([[c, s], [-s, c]])


def _normalise(uv):
    """Box middle at the origin, larger side 1."""
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    return (uv - 0.5 * (lo + hi)) / np.max(hi - lo)


def _lines(rng, n_lines, stops, span, turn=0.0):
    """Finger lines across x in [0, span] (uneven), each running y over [0, 1] with
    ``stops[i]`` uneven stops; line ``i`` turned by ``turn`` rad about its start if i = 0."""
    gaps = rng.uniform(0.3, 1.0, n_lines - 1)
    xs = np.concatenate([[0.0], np.cumsum(gaps)])
    xs = span * xs / xs[-1]
    uv, finger = [], []
    for i, (x, m) in enumerate(zip(xs, stops)):
        steps = rng.uniform(0.5, 1.5, m - 1)
        y = np.concatenate([[0.0], np.cumsum(steps)])
        y /= y[-1]
        pts = np.column_stack([np.full(m, x), y])
        if i == 0 and turn:
            pts = _turn(pts - pts[:1], turn) + pts[:1]
        uv.append(pts)
        finger.append(np.full(m, i))
    return np.vstack(uv), np.concatenate(finger)


def sweep(rng):
    n_lines = int(rng.integers(2, 5))
    stops = rng.integers(5, 13, n_lines)
    turn = np.radians(rng.uniform(5, 25)) * rng.choice([-1, 1]) if rng.random() < 1 / 3 else 0.0
    uv, finger = _lines(rng, n_lines, stops, rng.uniform(0.4, 1.0), turn)
    return uv, finger


def grid(rng):
    nx, ny = (int(v) for v in rng.integers(3, 7, 2))
    aspect = rng.uniform(0.5, 1.0)
    gx, gy = np.meshgrid(np.linspace(0, 1, nx), np.linspace(0, aspect, ny), indexing="ij")
    uv = np.column_stack([gx.ravel(), gy.ravel()])
    cell = np.array([1.0 / (nx - 1), aspect / (ny - 1)])
    uv = uv + rng.uniform(-0.15, 0.15, uv.shape) * cell
    return uv, np.repeat(np.arange(nx), ny)


def scatter(rng, n=None):
    n = int(rng.integers(10, 41)) if n is None else n
    uv = rng.uniform(0, 1, (n, 2)) * [1.0, rng.uniform(0.5, 1.0)]
    return uv, np.arange(n)


def small(rng):
    n = int(rng.integers(6, 10))
    if rng.random() < 0.5:
        return scatter(rng, n)
    n_lines = int(rng.integers(2, 4))
    stops = np.full(n_lines, n // n_lines)
    stops[: n % n_lines] += 1
    stops = np.clip(stops, 2, 4)
    return _lines(rng, n_lines, stops, rng.uniform(0.5, 1.0))


def place(kind, rng):
    """(uv, finger) of a ``kind`` layout, turned at random, larger side 1, middle at 0."""
    uv, finger = {"sweep": sweep, "grid": grid, "scatter": scatter, "small": small}[kind](rng)
    uv = _turn(uv, rng.uniform(0, 2 * np.pi))
    return _normalise(uv), np.asarray(finger, int)
