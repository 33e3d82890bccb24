"""A constant tilt between the normals and the positions (a mis-tared or weighted sensor).

Every normal turned by one small rotation about an axis across the patch adds one constant
to each of the slopes the normals give (dz/dx = -nx/nz, dz/dy = -ny/nz, §4.5.1), while the
positions are untouched.  ``estimate`` fits, in the patch frame (z along the mean normal,
lengths in units of the patch), one quadratic to the heights and its gradient plus two
constants (``bx``, ``by``) to the slopes: the constants are the tilt, the quadratic's
second derivatives the curvature, which a constant tilt does not move.  Rows are weighted
by each kind's noise: the residual scatter of the heights' own quadratic and of the slopes'
own plane, or the stated noise where larger (a strongly curved patch's own misfit then
counts as noise: with the stated noise alone it would refuse every tilt there).  The
constants' covariance is the fit's at chi^2/dof (at least 1); a chi^2/dof over
``MAX_CHI2`` means a tilt does not explain what the positions and normals disagree on.

Where the tilt is ``MIN_DEG``-``MAX_DEG`` and over ``MIN_Z`` of its standard error, ``untilt``
turns the normals back by it and names it in a warning, ``normals tilted 3.1 deg +/- 0.4
from the positions: a mis-tared or weighted sensor?``; the curvature is then fitted from
the corrected normals and the positions, instead of the patch being refused as "positions
and normals disagree".  Patches of fewer than ``MIN_POINTS`` contacts, or whose heights
and slopes together cannot tell a tilt from the surface's own slope, are left as they are.
"""

from dataclasses import replace

import numpy as np

from tactile.ep2.curvature_jump import tangent_basis

MIN_POINTS = 10
MIN_DEG = 1.0
MAX_DEG = 10.0  # beyond this it is no sensor's tare: the normals are another surface's
MIN_Z = 3.0
MAX_CHI2 = 4.0  # per spare row, with each kind's own noise: the tilt must explain the rest
NOISE_FLOOR = 1e-6  # of the patch size and rad: no noise is taken as zero


def _frame(nrm):
    """Rows x, y, z: two tangents across the normals' mean direction, then it."""
    m = nrm.sum(axis=0)
    m /= np.linalg.norm(m)
    return np.vstack([tangent_basis(m).T, m])


def _rows(x, y):
    one, zero = np.ones_like(x), np.zeros_like(x)
    height = np.column_stack([one, x, y, x * x / 2, x * y, y * y / 2, zero, zero])
    sx = np.column_stack([zero, one, zero, x, y, zero, one, zero])
    sy = np.column_stack([zero, zero, one, zero, x, y, zero, one])
    return height, sx, sy


def _rms(A, b, dof):
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    return np.sqrt(np.sum((A @ coef - b) ** 2) / max(dof, 1))


def estimate(points, normals, noise_pos=None, noise_normal=None):
    """(tilt (2,) slopes bx, by in the frame, its covariance (2, 2), frame rows (3, 3)), or
    None where the contacts cannot tell it."""
    pts, nrm = np.asarray(points, float), np.asarray(normals, float)
    n = len(pts)
    if n < MIN_POINTS:
        return None
    R = _frame(nrm)
    local = (pts - pts.mean(axis=0)) @ R.T
    L = max(np.ptp(local[:, 0]), np.ptp(local[:, 1]))
    if not L > 0:
        return None
    x, y, z = (local / L).T
    nl = nrm @ R.T
    if np.min(nl[:, 2]) <= 0.1:
        return None  # a normal near the tangent plane: slopes are not the right rows
    sx, sy = -nl[:, 0] / nl[:, 2], -nl[:, 1] / nl[:, 2]
    H, Sx, Sy = _rows(x, y)
    sp = _rms(H[:, :6], z, n - 6)
    Pn = np.column_stack([np.ones_like(x), x, y])
    sn = np.hypot(_rms(Pn, sx, n - 3), _rms(Pn, sy, n - 3)) / np.sqrt(2)
    if noise_pos is not None:
        sp = max(sp, noise_pos / L)  # (a strongly curved patch's own misfit counts too)
    if noise_normal is not None:
        sn = max(sn, noise_normal)
    sp, sn = max(sp, NOISE_FLOOR), max(sn, NOISE_FLOOR)
    A = np.vstack([H / sp, Sx / sn, Sy / sn])
    b = np.concatenate([z / sp, sx / sn, sy / sn])
    coef, _, rank, _ = np.linalg.lstsq(A, b, rcond=None)
    if rank < 8:
        return None  # the tilt cannot be told from the surface's own slope
    chi2 = np.sum((A @ coef - b) ** 2) / max(3 * n - 8, 1)
    try:  # (near a line: huge, so no tilt is named)
        cov = np.linalg.inv(A.T @ A) * max(chi2, 1.0)
    except np.linalg.LinAlgError:
        return None  # on one line: the tilt across it is not determined
    if chi2 > MAX_CHI2:
        return None  # a tilt does not explain the disagreement (a crease, another surface)
    return coef[6:], cov[6:, 6:], R


def untilt(prep):
    """(prep, warning): ``prep`` with its normals turned back by a tilt ``estimate`` finds
    (module docstring) and the warning naming it, or ``prep`` as it is and None."""
    got = estimate(prep.points, prep.normals, prep.jet.noise_pos, prep.jet.noise_normal)
    if got is None:
        return prep, None
    b, cov, R = got
    size = float(np.hypot(*b))
    if size == 0.0:
        return prep, None
    u = b / size
    se = float(np.sqrt(max(u @ cov @ u, 0.0)))
    deg = np.degrees(np.arctan(size))
    if not MIN_DEG <= deg <= MAX_DEG or size < MIN_Z * se:
        return prep, None
    nl = prep.normals @ R.T
    s = np.column_stack([-nl[:, 0] / nl[:, 2] - b[0], -nl[:, 1] / nl[:, 2] - b[1]])
    fixed = np.column_stack([-s, np.ones(len(s))])
    fixed /= np.linalg.norm(fixed, axis=1, keepdims=True)
    warning = (
        f"normals tilted {deg:.1f} deg +/- {np.degrees(se):.1f} from the positions:"
        " a mis-tared or weighted sensor?"
    )
    return replace(prep, normals=fixed @ R), warning
