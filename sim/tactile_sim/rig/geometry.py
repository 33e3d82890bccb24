"""The ch. 5 rig: Freddy, a 3-DOF SCARA with a vertical axis, and the wheel probe (fig. 38).

The thesis gives no dimensions (figures only); these are plausible for a bench SCARA of the
time and for the probe of fig. 37, in metres (docs/localize.md):

    L1 = 0.35, L2 = 0.30       upper arm and forearm
    L3 = 0.12                  probe shaft, sensor origin to wheel centre
    L4 = 0.015                 wheel radius (1.5 cm)
    half_thickness = 0.004     the rim is 8 mm thick
    shaft_radius = 0.004       the shaft hides the rim for |theta| > pi - asin(0.004/0.015)

Forward kinematics here compose planar homogeneous transforms link by link (a route
independent of the closed form in ``tactile.localize.world``, so tests can compare
them).  Inverse kinematics place the wheel centre: ``ik`` for a chosen shaft heading (free
wrist), ``ik_fixed_wrist`` for a given q3 (Freddy's fixed wrist, §5.1.3).
"""

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

__all__ = ["Rig", "FREDDY", "planar", "fk", "ik", "ik_fixed_wrist"]


@dataclass(frozen=True)
class Rig:
    L1: float = 0.35
    L2: float = 0.30
    L3: float = 0.12
    L4: float = 0.015
    half_thickness: float = 0.004
    shaft_radius: float = 0.004
    elbow: int = 1  # +1 or -1: which of the two 2-link IK branches

    @property
    def arc_limit(self):
        """Largest |theta| (from the shaft axis) at which the rim is not hidden by the shaft."""
        return float(np.pi - np.arcsin(min(self.shaft_radius / self.L4, 1.0)))

    @property
    def centre(self):
        """Wheel centre in the sensor frame."""
        return np.array([self.L3, 0.0, 0.0])


FREDDY = Rig()


def planar(angle, length):
    """3x3 homogeneous transform: rotate by ``angle`` then translate ``length`` along new x."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, length * c], [s, c, length * s], [0.0, 0.0, 1.0]])


def fk(rig, q):
    """Sensor pose (R 3x3, t 3) for one joint vector q = (q1, q2, q3, z)."""
    q1, q2, q3, z = q
    T = planar(q1, rig.L1) @ planar(q2, rig.L2) @ planar(q3, 0.0)
    R = np.eye(3)
    R[:2, :2] = T[:2, :2]
    return R, np.array([T[0, 2], T[1, 2], z])


def _two_link(rig, w):
    """(q1, q2) placing the wrist at ``w`` (2,), or None if out of reach."""
    L1, L2 = rig.L1, rig.L2
    D = (w @ w - L1 * L1 - L2 * L2) / (2.0 * L1 * L2)
    if abs(D) > 1.0:
        return None
    q2 = rig.elbow * np.arccos(D)
    q1 = np.arctan2(w[1], w[0]) - np.arctan2(L2 * np.sin(q2), L1 + L2 * np.cos(q2))
    return q1, q2


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def ik(rig, centre, heading):
    """Joints (q1, q2, q3, z) putting the wheel centre at ``centre`` (3,) with the shaft at
    world ``heading``; ValueError when out of reach."""
    c = np.asarray(centre, dtype=float)
    w = c[:2] - rig.L3 * np.array([np.cos(heading), np.sin(heading)])
    sol = _two_link(rig, w)
    if sol is None:
        raise ValueError(f"wheel centre {c[:2]} is out of the arm's reach")
    q1, q2 = sol
    return np.array([q1, q2, _wrap(heading - q1 - q2), c[2]])


def ik_fixed_wrist(rig, centre, q3, guess):
    """Joints with the wrist held at ``q3``: solve heading psi with
    psi = q1(psi) + q2(psi) + q3 (one scalar root, bracketed around ``guess``)."""

    def g(psi):
        w = np.asarray(centre, float)[:2] - rig.L3 * np.array([np.cos(psi), np.sin(psi)])
        sol = _two_link(rig, w)
        if sol is None:
            return np.nan
        return _wrap(sol[0] + sol[1] + q3 - psi)

    grid = guess + np.linspace(-0.6, 0.6, 49)
    vals = np.array([g(p) for p in grid])
    for k in np.argsort(np.abs(grid - guess)):
        for j in (k, k - 1):
            if 0 <= j < len(grid) - 1:
                a, b = vals[j], vals[j + 1]
                if np.isfinite(a) and np.isfinite(b) and a * b <= 0.0 and abs(a - b) < 1.0:
                    psi = brentq(g, grid[j], grid[j + 1], xtol=1e-14)
                    return ik(rig, centre, psi)
    raise ValueError(f"no fixed-wrist (q3 = {q3:.3f}) solution near heading {guess:.3f}")
