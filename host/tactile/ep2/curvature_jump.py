"""A curvature jump inside a patch: a plane joined tangentially to a cylinder, a fillet's end.

The normals stay continuous across such a join but turn at two different rates either side
of it, which no single 2-jet follows.  ``find`` looks along the direction ``x`` in which the
normals turn most (across the patch, in the frame of the mean normal) and compares two fits
of the normals' component along it:

- smooth: a quadratic in the patch coordinates (x, y), any 2-jet and a cubic's slopes;
- jump: the same plus a hinge (x - x0)+, the rate of turn changing at x0 (searched over
  the contacts' 15-85 % quantiles of x).

The hinge is a jump where it takes the residual down by more than ``MIN_F`` times its
remaining variance per spare row (an F statistic; the search over x0 is why the bar is
high).  ``api`` then labels the patch ``uncertain`` and names where the jump is: a 2-jet's
curvature at the centre is then an average over two surfaces, and its interval holds
neither one's.
"""

from dataclasses import dataclass

import numpy as np

MIN_POINTS = 12
MIN_F = 60.0
QUANTILES = np.linspace(0.15, 0.85, 15)
VAR_FLOOR = 0.003**2  # rad^2: no sensor's normals are better; a smooth surface's own
# misfit to the quadratic (a noise-free torus) stays under it
MIN_TURN_DEG = 2.0  # a turn in the normals' rate below this over the patch is noise's


@dataclass
class Jump:
    point: np.ndarray  # (3,) on the join, the input frame
    direction: np.ndarray  # (3,) along the join
    F: float

    def describe(self):
        p = ", ".join(f"{v:.4g}" for v in self.point)
        d = ", ".join(f"{v:.3f}" for v in self.direction)
        return (
            f"the curvature jumps across the patch at ({p}) along ({d}): the answer averages"
            " two surfaces, label uncertain; fit each side alone"
        )


def _basis(m):
    ref = np.array([1.0, 0.0, 0.0]) if abs(m[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(m, ref)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(m, t1)


def _rss(A, b):
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    return float(np.sum((A @ coef - b) ** 2))


def find(points, normals, middle=None):
    """The ``Jump`` inside the patch, or None (module docstring).  points, normals (n, 3);
    ``middle`` is added to the join's point (the patch's centring)."""
    pts, nrm = np.asarray(points, float), np.asarray(normals, float)
    n = len(pts)
    if n < MIN_POINTS:
        return None
    m = nrm.sum(axis=0)
    m /= np.linalg.norm(m)
    t1, t2 = _basis(m)
    g = nrm @ np.stack([t1, t2], axis=1)
    w, V = np.linalg.eigh(np.cov(g.T))
    a = V[0, 1] * t1 + V[1, 1] * t2  # the normals turn most along a
    b = np.cross(m, a)
    centre = pts.mean(axis=0)
    L = max(np.ptp(pts @ a), np.ptp(pts @ b))
    if not L > 0:
        return None
    x, y = (pts - centre) @ a / L, (pts - centre) @ b / L
    ga = nrm @ a
    A0 = np.column_stack([np.ones(n), x, y, x * x, x * y, y * y])
    if np.linalg.matrix_rank(A0) < 6:
        return None
    rss0 = _rss(A0, ga)
    best = None
    for x0 in np.quantile(x, QUANTILES):
        hinge = np.maximum(x - x0, 0.0)
        A1 = np.column_stack([A0, hinge])
        coef, *_ = np.linalg.lstsq(A1, ga, rcond=None)
        rss1 = float(np.sum((A1 @ coef - ga) ** 2))
        if best is None or rss1 < best[0]:
            best = (rss1, x0, coef[-1] * (x.max() - x0))
    rss1, x0, turn = best
    F = (rss0 - rss1) / max(rss1 / (n - 7), VAR_FLOOR)
    if F < MIN_F or abs(np.degrees(turn)) < MIN_TURN_DEG:
        return None
    point = centre + x0 * L * a + (0.0 if middle is None else middle)
    return Jump(point, b, float(F))
