"""Write localised contacts in the EP2 contacts-CSV contract (issue 3, §5.1.2).

Header row; ``x,y,z,nx,ny,nz`` (world frame; normals from the object toward the finger,
which is ``Contact.normal``), optional ``finger`` and ``patch``.  Only usable rows are
written, so the file never holds a non-contact or a NaN.
"""

import numpy as np

__all__ = ["format_contacts"]


def format_contacts(points, normals, finger=None, patch=None, scale=1.0, mask=None):
    """CSV text for world ``points``/``normals`` (n, 3).  ``scale`` converts the length unit
    (e.g. 100 for metres -> cm, the unit of the thesis's tables); ``mask`` selects rows."""
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
    lines = [",".join(cols)]
    for i in np.flatnonzero(keep):
        cells = [repr(float(v)) for v in (*P[i], *N[i])]
        cells += [str(e[i].item() if hasattr(e[i], "item") else e[i]) for e in extra]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"
