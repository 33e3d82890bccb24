"""Rolling without slipping: Montana's contact kinematics (§3.2.2, eqs. 24-28).

State ``y = (u1, v1, u2, v2, psi, s)``: contact point on the finger (p1) and on the object
(p2), the angle psi between the contact frames (eq. 26-27) and the arc length traced on the
finger (eq. 28).  The finger's angular velocity relative to the object is ``omega`` with
components on the finger's instantaneous contact frame (x1, y1, z1); rolling means the
linear velocity is zero.  With R_psi = [[cos, -sin], [-sin, -cos]] (eq. 26, its own inverse):

    K2~ = R_psi K2 R_psi,   q = (K1 + K2~)^-1 [-wy, wx]^T
    dp1/dt = M1^-1 q                              (eq. 24, v = 0)
    dp2/dt = M2^-1 R_psi q                        (eq. 25, v = 0)
    dpsi/dt = wz + T1 M1 dp1/dt + T2 M2 dp2/dt    (eq. 27)
    ds/dt = |q|                                   (eq. 28; |.| of the thesis's vector integrand)

``finger_pose`` rebuilds the finger's rotation and translation from a state, which the
tests use as an independent check (no slip, angular velocity as commanded) and the probe
model uses to measure the net rotation from the normals (eqs. 34-35).
"""

from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from tactile_sim.ep1.surfaces import local

__all__ = [
    "RollResult",
    "rhs",
    "roll",
    "finger_pose",
    "r_psi",
    "true_curvature",
    "sphere_on_sphere",
    "DEFAULT_METHOD",
    "DEFAULT_RTOL",
    "DEFAULT_ATOL",
]

# Chosen from bench/ep1_work_precision.py (docs/ep1.md): DOP853 reaches 1e-10 at the lowest
# cost of all methods on smooth non-stiff rolling; the problem is never stiff.
DEFAULT_METHOD = "DOP853"
DEFAULT_RTOL = 1e-10
DEFAULT_ATOL = 1e-12
CHART_MARGIN = 1e-6


class RollResult(NamedTuple):
    """End state of one roll and how it ended ('done', 'chart_exit:finger', 'chart_exit:object',
    'contact_lost')."""

    t: float
    y: np.ndarray  # (u1, v1, u2, v2, psi, s) at the end
    status: str
    nfev: int


def r_psi(psi):
    """R_psi of eq. 26 (symmetric, its own inverse)."""
    c, s = np.cos(psi), np.sin(psi)
    return np.array([[c, -s], [-s, -c]])


def true_curvature(obj, p2, psi=0.0):
    """K2~ = R_psi K2 R_psi at object point p2 (eq. 24's object curvature in the finger frame)
    and its principal curvatures (k1 >= k2): the truth an EP1 estimate is compared with."""
    R = r_psi(psi)
    K = R @ local(obj, p2[0], p2[1]).K @ R
    k2, k1 = np.linalg.eigvalsh(K)
    return {"kx": K[0, 0], "ky": K[1, 1], "K": K, "k1": k1, "k2": k2}


def _solve2(A, b):
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    return np.array([A[1, 1] * b[0] - A[0, 1] * b[1], A[0, 0] * b[1] - A[1, 0] * b[0]]) / det


def rhs(t, y, finger, obj, omega):
    """Right-hand side of eqs. 24-28 for angular velocity ``omega = (wx, wy, wz)``."""
    g1 = local(finger, y[0], y[1])
    g2 = local(obj, y[2], y[3])
    R = r_psi(y[4])
    q = _solve2(g1.K + R @ g2.K @ R, np.array([-omega[1], omega[0]]))
    dp1 = _solve_upper(g1.M, q)
    r2 = R @ q
    dp2 = _solve_upper(g2.M, r2)
    dpsi = omega[2] + g1.T @ q + g2.T @ r2
    return np.array([dp1[0], dp1[1], dp2[0], dp2[1], dpsi, np.hypot(q[0], q[1])])


def _solve_upper(M, b):
    y1 = b[1] / M[1, 1]
    return np.array([(b[0] - M[0, 1] * y1) / M[0, 0], y1])


def _chart_events(finger, obj, check_contact=True):
    events = []
    for idx, surf, label in ((0, finger, "finger"), (2, obj, "object")):
        for k in (0, 1):
            lo, hi = surf.chart[k]

            def ev(t, y, *a, i=idx + k, lo=lo, hi=hi):
                return min(y[i] - lo, hi - y[i]) - CHART_MARGIN

            ev.terminal, ev.direction, ev.label = True, -1, label
            events.append(ev)

    def contact(t, y, *a):
        # Contact is stable only while K1 + K2~ is positive definite (eq. 24 invertible).
        g1 = local(finger, y[0], y[1])
        g2 = local(obj, y[2], y[3])
        R = r_psi(y[4])
        A = g1.K + R @ g2.K @ R
        return min(A[0, 0] + A[1, 1], A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0])

    contact.terminal, contact.direction, contact.label = True, -1, "contact_lost"
    if check_contact:
        events.append(contact)
    return events


def roll(
    finger,
    obj,
    p1,
    p2,
    psi,
    omega,
    duration=1.0,
    method=None,
    rtol=None,
    atol=None,
    check_contact=True,
):
    """Integrate eqs. 24-28 for ``duration`` at constant contact-frame ``omega``.

    Stops early, with status 'chart_exit:finger|object' or 'contact_lost', when a contact
    point leaves its chart or K1 + K2~ stops being positive definite.
    """
    y0 = np.array([p1[0], p1[1], p2[0], p2[1], psi, 0.0], dtype=float)
    omega = np.asarray(omega, dtype=float)
    if omega.shape == (2,):
        omega = np.append(omega, 0.0)
    events = _chart_events(finger, obj, check_contact)
    sol = solve_ivp(
        rhs,
        (0.0, duration),
        y0,
        method=method or DEFAULT_METHOD,
        rtol=DEFAULT_RTOL if rtol is None else rtol,
        atol=DEFAULT_ATOL if atol is None else atol,
        args=(finger, obj, omega),
        events=events,
    )
    status = "done"
    if sol.status == 1:
        hit = next(i for i, te in enumerate(sol.t_events) if len(te))
        ev = events[hit]
        status = ev.label if ev.label == "contact_lost" else f"chart_exit:{ev.label}"
    elif sol.status < 0:
        status = "failed"
    return RollResult(float(sol.t[-1]), sol.y[:, -1].copy(), status, int(sol.nfev))


def axes(g):
    """A Gauss frame's axes as columns (3, 3)."""
    return np.column_stack([g.x, g.y, g.z])


def finger_pose(finger, obj, y):
    """Finger rotation R and translation t (object frame) for state ``y``.

    The finger frame at p1 maps onto the object frame at p2 rotated by psi about the common
    normal with z1 = -z2 (eq. 26), and the two contact points coincide.
    """
    g1 = local(finger, y[0], y[1])
    g2 = local(obj, y[2], y[3])
    c, s = np.cos(y[4]), np.sin(y[4])
    F_psi = np.array([[c, -s, 0.0], [-s, -c, 0.0], [0.0, 0.0, -1.0]])
    R = axes(g2) @ F_psi @ axes(g1).T
    return R, g2.point - R @ g1.point


def sphere_on_sphere(R1, R2, u0, v0, omega_x, omega_y, t=1.0):
    """Closed form of eq. 38 integrated: finger contact point after rolling on a sphere.

    u' = -wy c, v' = wx c / cos u with c = R2 / (R1 + R2) (R2 < 0 for a concave sphere,
    |R2| > R1).  Broadcasts over all arguments.  Returns (u, v) and arc length s = R1 c |w| t.
    """
    c = R2 / (R1 + R2)
    wx, wy = np.asarray(omega_x, float), np.asarray(omega_y, float)
    u = u0 - wy * c * t
    # dv/du = -(wx/wy) / cos u, so v - v0 = wx c t * [G(u) - G(u0)] / (u - u0) with
    # G = atanh(sin u), G' = 1/cos u; the divided difference is replaced by 1/cos(midpoint)
    # when u - u0 is tiny (error O(du^2)), which also covers wy = 0 exactly.
    du = u - u0
    small = np.abs(du) < 1e-6
    safe = np.where(small, 1.0, du)
    dd = np.where(
        small,
        1.0 / np.cos(u0 + 0.5 * du),
        (np.arctanh(np.sin(u)) - np.arctanh(np.sin(u0))) / safe,
    )
    v = v0 + wx * c * t * dd
    s = R1 * np.abs(c) * np.hypot(wx, wy) * t
    return u, v, s
