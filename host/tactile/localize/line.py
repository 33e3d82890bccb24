"""The line of action of a force from a force/moment reading (§5.1.1, principle of
transmissibility; Tsujimura & Yabuta, §3.3.3).

A point force F applied at p gives the moment M = (p - O) x F about the sensor origin O, so p
lies on the line {p : (p - O) x F = M}.  Its point closest to O is

    p0 = O + (F x M) / |F|^2,

since (F x M) x F = M |F|^2 - F (F . M) and F . M = 0 for a point force.  A measured M has a
component along F too (noise, or a torque the contact can transmit, as with a soft finger);
it cannot move the line and is reported as ``twist = M . F/|F|``.
"""

import numpy as np

__all__ = ["line_of_action", "entry_root"]


def line_of_action(force, moment, origin=(0.0, 0.0, 0.0)):
    """Return (p0, u, norm, twist): closest point to ``origin``, unit direction of F, |F| and
    the moment component along F.  Rows with F = 0 give u = 0, p0 = origin (gate them first)."""
    F = np.asarray(force, dtype=float)
    M = np.asarray(moment, dtype=float)
    norm = np.linalg.norm(F, axis=-1)
    safe = np.where(norm > 0.0, norm, 1.0)[..., None]
    u = F / safe
    p0 = np.asarray(origin, dtype=float) + np.cross(u, M) / safe
    twist = np.einsum("...i,...i->...", M, u)
    return p0, u, norm, twist


def entry_root(a, b, c):
    """Smaller root of a t^2 + 2 b t + c = 0 (a > 0), and the discriminant b^2 - a c.

    The smaller root is where a line running along +F first meets a convex surface: the
    point where the force presses INTO the probe.  Computed without cancellation (the
    product of the roots is c/a).  Where the discriminant is negative the root is the
    line's closest approach, -b/a.
    """
    disc = b * b - a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    # b > 0: -b - root has no cancellation.  b <= 0: the larger root (-b + root)/a is stable
    # and the smaller one is c / (-b + root).
    big = -b + root
    safe_big = np.where((b <= 0.0) & (big != 0.0), big, 1.0)  # only the branch that is used
    t = np.where(b > 0.0, (-b - root) / a, np.where(big != 0.0, c / safe_big, 0.0))
    t = np.where(disc >= 0.0, t, -b / a)
    return t, disc
