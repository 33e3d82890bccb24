"""One EP1 run end to end: simulate the '+' probes, measure, estimate, compare with the truth.

The simulator (``tactile_sim.ep1``) makes the probes and the truth; the host's estimator
(``tactile.ep1``) reads them: an application-layer study (``tactile sim ep1``).
"""

import numpy as np

from tactile.ep1.estimator import estimate
from tactile_sim.ep1.probes import PLUS, measure, simulate_probes
from tactile_sim.ep1.rolling import true_curvature
from tactile_sim.ep1.surfaces import fingertip

__all__ = ["run_ep1"]


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
    finger = fingertip(finger_radius)
    probes = simulate_probes(finger, obj, p1, p2, dtheta, phis, **roll_kw)
    rng = np.random.default_rng(seed)
    rows = measure(probes, finger_radius, sigma_theta, resolution, sensor, rng)
    est = estimate(rows[:, :2], rows[:, 2:], finger_radius, p1[0], resolution, sigma_theta)
    return rows, est, true_curvature(obj, p2), probes
