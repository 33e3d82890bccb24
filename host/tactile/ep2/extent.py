"""The coordinates EP2 can represent, and contacts moved to where their arithmetic is safe.

Both fits work in a frame scaled by the patch size L (``local_jet``, ``spline_analysis``),
so the fit itself does not care about the length unit.  What does care is the way in and
the way out: a centroid of coordinates near 1e308 overflows, and so does a curvature of
1/L for L = 1e-310, or a Gaussian curvature 1/L^2 beyond L ~ 1e+-154.  So:

- the contacts' spread (the largest side of their bounding box) must lie in
  [``MIN_SPREAD``, ``MAX_SPREAD``] length units, which keeps every reported length and
  curvature a finite float; outside it ``spread_problem`` says why, naming the row that
  sets the spread (``InputError``, exit 2: the input cannot be represented, whatever the
  data say).  A spread of exactly 0 is left to the fit, which refuses it as data that do
  not determine a curvature (exit 3);
- ``centred`` moves the middle of their box to the origin before anything is summed,
  and the caller adds it back to the patch frame's origin.

Normals need no range: ``patch_frame.unit_normals`` normalises any finite non-zero vector.
"""

import numpy as np

MIN_SPREAD = 1e-300
MAX_SPREAD = 1e300
AXES = "xyz"


def box(points):
    """(middle (3,), half sides (3,)) of the points' bounding box, without overflow."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return 0.5 * lo + 0.5 * hi, 0.5 * hi - 0.5 * lo


def spread_problem(points):
    """None, or (row, axis index, message) when the spread is outside the range EP2 holds.

    ``row`` is the contact that sets the spread along ``axis`` (the one farthest from the
    median there), so a single wild coordinate is named.
    """
    pts = np.asarray(points, float)
    if not len(pts):
        return None
    _, half = box(pts)
    axis = int(np.argmax(half))
    h = float(half[axis])
    if h == 0.0 or MIN_SPREAD <= 2.0 * h <= MAX_SPREAD:
        return None
    col = pts[:, axis]
    med = float(np.median(col))
    row = int(np.argmax(np.abs(0.5 * col - 0.5 * med)))
    span = f"{2.0 * h:.3g}" if h < 8.9e307 else "more than 1.8e+308"
    if 2.0 * h > MAX_SPREAD:
        why = (
            f"the contacts spread over {span} along {AXES[axis]}, beyond the {MAX_SPREAD:g}"
            f" EP2 can represent ({AXES[axis]} = {col[row]:.6g} here): check that value, or"
            " use a larger length unit"
        )
    else:
        why = (
            f"the contacts spread over only {span}, under the {MIN_SPREAD:g} EP2 can"
            " represent: use a smaller length unit"
        )
    return row, axis, why


def centred(points):
    """(points - middle of their box, middle): nothing downstream sums raw coordinates."""
    pts = np.asarray(points, float)
    middle, _ = box(pts)
    return pts - middle, middle
