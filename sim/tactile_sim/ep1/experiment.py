"""One EP1 run end to end: simulate the '+' probes, measure, estimate, compare with the truth.

Functional and arrays-in/arrays-out so the board emulator can drive the same pieces.
"""

import numpy as np

from tactile_sim.ep1.probes import PLUS, measure, simulate_probes
from tactile_sim.ep1.rolling import r_psi
from tactile_sim.ep1.surfaces import fingertip, local

__all__ = ["true_curvature", "run_ep1"]


def true_curvature(obj, p2, psi=0.0):
    """K2~ = R_psi K2 R_psi at object point p2 (eq. 24's object curvature in the finger frame)
    and its principal curvatures (k1 >= k2)."""
    R = r_psi(psi)
    K = R @ local(obj, p2[0], p2[1]).K @ R
    k2, k1 = np.linalg.eigvalsh(K)
    return {"kx": K[0, 0], "ky": K[1, 1], "K": K, "k1": k1, "k2": k2}


def run_ep1(
    obj,
    finger_radius,
    dtheta,
    p2=(0.0, 0.0),
    p1=(0.0, 0.0),
    phis=PLUS,
    sigma_theta=0.0,
    resolution=0.0,
    sensor="array",
    seed=None,
    **roll_kw,
):
    """Simulate, measure and estimate; return (rows (m, 4), Estimate, truth dict, probes)."""
    from tactile.ep1.estimator import estimate

    finger = fingertip(finger_radius)
    probes = simulate_probes(finger, obj, p1, p2, dtheta, phis, **roll_kw)
    rng = np.random.default_rng(seed)
    rows = measure(probes, finger_radius, sigma_theta, resolution, sensor, rng)
    est = estimate(rows[:, :2], rows[:, 2:], finger_radius, p1[0], resolution, sigma_theta)
    return rows, est, true_curvature(obj, p2), probes
