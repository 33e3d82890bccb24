"""Discontinuities along a finger's sweep (§6.2.2, §6.2.5).

A crease or edge shows as consecutive normals of one finger that differ by
more than an angle.  ``find_breaks`` lists them (``find_breaks_many``: for a
stack of patches at once, the same lists); ``split_parts`` cuts every finger's
sequence at its breaks and groups the k-th piece of each finger into part k, so
each part can be fitted as its own patch.
"""

import numpy as np

BREAK_ANGLE_DEG = 30.0


def find_breaks(normals, finger, max_angle_deg=BREAK_ANGLE_DEG):
    """List of (row index, finger, angle in deg) where the normal turns too far.

    ``normals`` are unit rows in sweep order within each finger; ``finger``
    labels rows (None: no finger information, nothing is checked).
    """
    if finger is None:
        return []
    finger = np.asarray(finger)
    out = []
    for f in dict.fromkeys(finger.tolist()):
        rows = np.flatnonzero(finger == f)
        if rows.size < 2:
            continue
        dots = np.einsum("ij,ij->i", normals[rows[:-1]], normals[rows[1:]])
        cross = np.linalg.norm(np.cross(normals[rows[:-1]], normals[rows[1:]]), axis=1)
        angle = np.degrees(np.arctan2(cross, dots))
        for j in np.flatnonzero(angle > max_angle_deg):
            out.append((int(rows[j + 1]), f, float(angle[j])))
    return out


def find_breaks_many(normals, fingers, max_angle_deg=BREAK_ANGLE_DEG):
    """``[find_breaks(normals[b], fingers[b], max_angle_deg) for b]`` for a stack ``normals``
    (B, n, 3), with the pairs of every patch whose labels share a type measured together
    (the same arithmetic, so the same rows, labels and angles).  Labels of another kind
    (objects, dates, a length that is not n) go through ``find_breaks`` one patch at a time."""
    out = [[] for _ in fingers]
    kinds = {}
    for b, f in enumerate(fingers):
        if f is None:
            continue
        f = np.asarray(f)
        if f.shape != normals.shape[1:2] or f.dtype.kind not in "biufUS":
            out[b] = find_breaks(normals[b], f, max_angle_deg)
        else:  # numbers of one dtype together (int64 and float64 differ above 2^53)
            kinds.setdefault(f.dtype.kind if f.dtype.kind in "US" else f.dtype, []).append((b, f))
    for group in kinds.values():
        for b, row, first, angle in _stacked(normals, group, max_angle_deg):
            out[b].append((row, first, angle))
    return out


def _stacked(normals, group, max_angle_deg):
    """(patch, row, label, angle) of every break of ``group``'s patches, [(b, labels)], in
    ``find_breaks``'s order: by patch, label (first appearance), row."""
    bs = np.array([b for b, _ in group])
    labels = np.stack([f for _, f in group])
    if labels.dtype.kind == "f":
        labels = labels + 0.0  # -0.0 sorts with 0.0, as == (and a dict) has them
    # a stable sort puts each label's rows together in sweep order: a pair of neighbours
    # with equal labels is a consecutive pair of one finger (NaN equals nothing, as in ==)
    order = np.argsort(labels, axis=1, kind="stable")
    ranked = np.take_along_axis(labels, order, axis=1)
    same = ranked[:, 1:] == ranked[:, :-1]
    g, k = np.nonzero(same)
    a, b = normals[bs[g], order[g, k]], normals[bs[g], order[g, k + 1]]
    dots = np.einsum("ij,ij->i", a, b)
    cross = np.linalg.norm(np.cross(a, b), axis=1)
    angle = np.degrees(np.arctan2(cross, dots))
    hit = np.flatnonzero(angle > max_angle_deg)
    if not hit.size:
        return []
    # each run of equal labels starts at its label's first row (a stable sort)
    cols = np.arange(labels.shape[1])
    start = np.maximum.accumulate(np.where(np.c_[np.ones(len(bs), bool), ~same], cols, 0), axis=1)
    g, k = g[hit], k[hit]
    row, first = order[g, k + 1], order[g, start[g, k]]
    out, listed = [], {}  # labels as Python values, as ``find_breaks`` gives them
    for h in np.lexsort((row, first, g)).tolist():
        p = int(g[h])
        if p not in listed:
            listed[p] = group[p][1].tolist()
        out.append((int(bs[p]), int(row[h]), listed[p][first[h]], float(angle[hit[h]])))
    return out


def split_parts(n_rows, finger, breaks):
    """Row-index arrays of the parts left after cutting each finger at its breaks."""
    part = np.zeros(n_rows, dtype=int)
    finger = np.asarray(finger)
    cut = {}
    for row, f, _ in breaks:
        cut.setdefault(f, []).append(row)
    for f, rows_cut in cut.items():
        rows = np.flatnonzero(finger == f)
        for r in rows_cut:
            part[rows[rows >= r]] += 1
    return [np.flatnonzero(part == k) for k in range(part.max() + 1) if np.any(part == k)]
