"""Write localised contacts in the EP2 contacts-CSV contract (issue 3, §5.1.2).

A ``# units: m`` line, then a header row; ``x,y,z,nx,ny,nz`` (world frame; normals from the
object toward the finger, which is ``Contact.normal``), optional ``finger`` and ``patch``.
Only usable rows are written, so the file never holds a non-contact or a NaN.
"""

import numpy as np

from tactile import units

__all__ = ["format_contacts"]


def format_contacts(points, normals, finger=None, patch=None, unit=units.CONTACTS, mask=None):
    """CSV text for world ``points`` (metres) and ``normals`` (n, 3), under a ``# units:``
    line.  ``unit`` another length unit to write them in (SI unless asked); ``mask`` selects
    rows."""
    scale = units.LENGTH_M[units.SI_LENGTH] / units.length_factor(unit)
    P = np.asarray(points, dtype=float).reshape(-1, 3) * scale
    N = np.asarray(normals, dtype=float).reshape(-1, 3)
    keep = np.ones(len(P), bool) if mask is None else np.asarray(mask, bool).ravel()
    keep &= np.isfinite(P).all(axis=1) & np.isfinite(N).all(axis=1)
    keep &= np.linalg.norm(N, axis=1) > 0.0
    cols = ["x", "y", "z", "nx", "ny", "nz"]
    extra = []
    if finger is not None:
        cols.append("finger")
        extra.append(np.broadcast_to(np.asarray(finger), (len(P),)))
    if patch is not None:
        cols.append("patch")
        extra.append(np.broadcast_to(np.asarray(patch), (len(P),)))
    lines = [units.line(units.parse_length(unit)).rstrip("\n"), ",".join(cols)]
    for i in np.flatnonzero(keep):
        cells = [repr(float(v)) for v in (*P[i], *N[i])]
        cells += [str(e[i].item() if hasattr(e[i], "item") else e[i]) for e in extra]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"
