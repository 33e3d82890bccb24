"""Contacts that are no part of the surface the others describe (``local_jet``, item 4):
normals over the angle limit from the patch's, and the contact whose residuals fail a
deletion test at the patch's robust scale, if it is also gross and alone."""

import math

import numpy as np

from tactile.ep2.jet_terms import mv, pick, size, unit, vm

MAX_OUTLIERS = 2  # contacts left out by the deletion test; one more refuses the patch
GROSS_POSITION = 0.05  # of L: a point off by less is not called an outlier, whatever the test
GROSS_ANGLE = 10.0  # deg: nor a normal turned by less
ISOLATED = 4.0  # an outlier's statistic is this many times that of the contacts after the worst


def worst_contact(f, keep):
    """Per patch: the index of the contact that fails the deletion test worst (-1: none),
    and what is wrong with it, in words.  The test: the contact's three residuals in the top
    jet, each over (1 - its leverage), against the patch's robust scale (their median), at
    1e-3 / n; and gross: its point GROSS_POSITION off, or its normal GROSS_ANGLE."""
    n = f.n
    r, h = pick(f.resid, f.quiet), pick(f.hat, f.quiet)
    part = r * r / (1.0 - np.minimum(h, 0.999))
    pos, slope = part[:, :n], part[:, n : 2 * n] + part[:, 2 * n :]
    stat = np.where(keep, pos + slope, np.nan)
    dof = 3 * keep.sum(-1) - np.array([size(int(o)) for o in f.quiet])
    s2 = np.nanmedian(stat, axis=-1) / 2.366  # (the median of chi^2_3)
    s2 = np.where(f.stated.all(-1), np.maximum(s2, 1.0), s2)
    s2 = np.where(np.isfinite(s2) & (s2 > 0), s2, 1.0)
    z = np.where(keep, stat / s2[:, None], -1.0)
    worst = np.argmax(z, -1)
    idx = np.arange(len(z))
    w = f.w
    off = np.abs(r[:, :n]) / np.where(w[:, :n] > 0, w[:, :n], 1.0)  # (in L)
    ds = np.hypot(r[:, n : 2 * n] / np.where(w[:, n : 2 * n] > 0, w[:, n : 2 * n], 1.0),
                  r[:, 2 * n :] / np.where(w[:, 2 * n :] > 0, w[:, 2 * n :], 1.0))  # fmt: skip
    turn = np.degrees(np.arctan(ds / (1.0 + f.g2)))  # (a slope change, as an angle)
    gross = (off[idx, worst] > GROSS_POSITION) | (turn[idx, worst] > GROSS_ANGLE)
    limit = 16.27 + 2.0 * np.log(np.maximum(keep.sum(-1), 1))
    third = -np.sort(-z, -1)[:, min(MAX_OUTLIERS, z.shape[1] - 1)]
    alone = z[idx, worst] > ISOLATED * np.maximum(third, 1.0)  # (a misfit spreads over many)
    bad = (z[idx, worst] > limit) & (dof >= 4) & gross & alone
    why = [None] * len(z)
    for b in np.flatnonzero(bad):
        k = worst[b]
        if pos[b, k] >= slope[b, k]:
            why[b] = f"its point is {off[b, k] * f.L[b]:.3g} off the surface the others describe"
        else:
            why[b] = f"its normal is {turn[b, k]:.0f} deg off the surface's there"
    return np.where(bad, worst, -1), why


def screen_normals(N, mask, max_angle):
    """Contacts whose normal is over MAX_ANGLE from the patch's mean normal (seeded at the
    medoid: the normal closest to all others) are left out, with a warning each.  A normal's
    summed agreement with all the others, sum_j n_i . n_j, is n_i . (sum_j n_j): one pass
    over the rows, no n x n matrix."""
    cosmax = math.cos(math.radians(max_angle))
    medoid = np.argmax(np.where(mask, mv(N, vm(mask.astype(float), N)), -np.inf), axis=-1)
    seed = N[np.arange(len(N)), medoid]
    near = mask & (mv(N, seed) > cosmax)
    mean = unit(vm(near.astype(float), N))
    cos = mv(N, mean)
    keep = mask & (cos > cosmax)
    warnings = [[] for _ in range(len(N))]
    for b, k in zip(*np.nonzero(mask & ~keep), strict=True):
        angle = math.degrees(math.acos(max(-1.0, min(1.0, float(cos[b, k])))))
        warnings[b].append(
            f"contact {k} left out: its normal is {angle:.0f} deg from its neighbours' "
            f"(limit {max_angle:g} deg, --max-normal-angle)"
        )
    return keep, warnings
