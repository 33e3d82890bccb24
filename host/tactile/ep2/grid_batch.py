"""The thesis's grid statistics (§4.8.2) for a whole stack of centre-jet fits at once.

Per patch: the fitted surface's (z_x, z_y, z_xx, z_xy, z_yy) on an N x N grid over the
contacts' box (final frame, / L), then mean and sd of k1, k2, R, S and C over the grid
points where the surface is finite (a steep fit can overflow far from the centre).
``centre_result.grid_statistics`` is the one-patch form the spline path uses; both give
the same numbers (tested).
"""

import numpy as np

from tactile.ep2.shape_index import curvedness_c, curvedness_r, shape_index
from tactile.ep2.surface_geometry import eigen, shape_entries

DERIVS = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
KEYS = ("R_mean", "R_std", "k1_mean", "k2_mean", "k1_std", "k2_std", "S_mean", "S_std", "C_mean")


def moments(ch):
    """Grid means and sds of k1, k2, R, S and C (in units of the patch: / L, C of R / L
    is taken later) per patch: dict of (B,) arrays, NaN where no grid point is finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        k1, k2 = eigen(*shape_entries(*ch))
    ok = np.isfinite(k1) & np.isfinite(k2)
    k1, k2 = np.where(ok, k1, 0.0), np.where(ok, k2, 0.0)
    r = curvedness_r(k1, k2)
    s = shape_index(k1, k2)
    out = {}
    for name, v in (("k1", k1), ("k2", k2), ("R", r), ("S", s)):
        out[name + "_mean"], out[name + "_std"] = _mean_sd(v, ok)
    return out, (r, ok)


def statistics(ch, scale):
    """Everything per patch the grid statistics need, before the label is known: dict of
    (B,) arrays (``moments``, lengths still / L), ``C_mean`` of R / ``scale`` (B,), and
    ``any`` / ``any_pos``: whether any grid point is finite / has R > 0."""
    m, (r, ok) = moments(ch)
    pos = ok & (r > 0)
    c = np.where(pos, curvedness_c(np.where(pos, r, 1.0) / scale[:, None]), 0.0)
    m["C_mean"], _ = _mean_sd(c, pos)
    m["any"], m["any_pos"] = ok.any(axis=-1), pos.any(axis=-1)
    return m


def at(stats, i, scale, plane):
    """Patch ``i``'s grid statistics (dict of ``KEYS``, as ``centre_result.grid_statistics``):
    lengths / ``scale``; S and C null for a plane or where no grid point is finite."""
    if not stats["any"][i]:
        return dict.fromkeys(KEYS)
    d = {k: float(stats[k][i]) / scale for k in KEYS[:6]}
    d.update(S_mean=None, S_std=None, C_mean=None)
    if not plane:
        d.update(S_mean=float(stats["S_mean"][i]), S_std=float(stats["S_std"][i]))
        if stats["any_pos"][i]:
            d["C_mean"] = float(stats["C_mean"][i])
    return d


def _mean_sd(v, ok):
    """Mean and population sd of ``v`` over ``ok`` along the last axis (two passes)."""
    count = np.maximum(ok.sum(axis=-1), 1)
    mean = np.where(ok, v, 0.0).sum(axis=-1) / count
    dev = np.where(ok, v - mean[..., None], 0.0)
    return mean, np.sqrt((dev * dev).sum(axis=-1) / count)
