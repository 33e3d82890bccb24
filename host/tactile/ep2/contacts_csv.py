"""The EP2 contacts CSV contract (issue 3).

Header row; columns ``x,y,z,nx,ny,nz`` required, ``finger`` and ``patch``
optional, other columns ignored, ``#`` comment lines allowed; any consistent
length unit.  Rows are grouped by ``patch`` (first-appearance order; no column
means one patch) and kept in file order within a patch, which is the sweep
order the discontinuity check relies on.
"""

from dataclasses import dataclass

import numpy as np

from tactile.ep2 import extent
from tactile.errors import InputError, where
from tactile.tabular import read_csv, show

REQUIRED = ("x", "y", "z", "nx", "ny", "nz")


@dataclass
class Contacts:
    """One patch's contacts: points and normals (n, 3), finger labels or None, source lines."""

    patch: str | None
    points: np.ndarray
    normals: np.ndarray
    finger: list | None
    lines: list


def read_contacts(path):
    """Read ``path`` into a list of ``Contacts`` (one per patch)."""
    table = read_csv(path, REQUIRED, optional_text=("finger", "patch"))
    pts = table.array("x", "y", "z")
    nrm = table.array("nx", "ny", "nz")
    bad = np.flatnonzero(~(np.max(np.abs(nrm), axis=1) > 0))
    if bad.size:
        raise InputError(f"{where(path, table.lines[bad[0]], 'nx')}: zero-length normal (nx,ny,nz)")
    finger = table.columns.get("finger")
    patch = table.columns.get("patch")
    if patch is None:
        return _checked(path, [Contacts(None, pts, nrm, finger, list(table.lines))])
    names, rows = group_rows(patch)
    lines = np.asarray(table.lines, dtype=np.int64)
    out = [
        Contacts(
            name,
            pts[r],
            nrm[r],
            None if finger is None else [finger[i] for i in r],
            lines[r].tolist(),
        )
        for name, r in zip(names, rows)
    ]
    return _checked(path, out)


def group_rows(ids):
    """Group row indices by id in one pass: (ids in order of first appearance, one int64
    index array per id with its rows in file order).  Linear in the rows, however the ids
    are interleaved (a stable sort of small integer codes)."""
    code_of = {}
    codes = np.fromiter((code_of.setdefault(p, len(code_of)) for p in ids), np.int64, len(ids))
    order = np.argsort(codes, kind="stable")
    ends = np.cumsum(np.bincount(codes, minlength=len(code_of)))
    return list(code_of), np.split(order, ends[:-1])


def _checked(path, groups):
    """Refuse a patch whose coordinates EP2 cannot represent (``extent``), at the row
    that sets its spread."""
    for g in groups:
        problem = extent.spread_problem(g.points)
        if problem is not None:
            row, axis, why = problem
            name = "" if g.patch is None else f"patch {show(g.patch)}: "
            raise InputError(f"{where(path, g.lines[row], extent.AXES[axis])}: {name}{why}")
    return groups
