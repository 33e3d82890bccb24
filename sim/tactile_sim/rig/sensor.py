"""The F/T sensor of ch. 5: units, accuracy and noise (§5.1, §5.1.3).

The thesis's sensor (ATI, ref. [3]) is "accurate to 0.20 oz in x and y and 0.40 oz in z".
Our wire streams newtons, so with 1 ozf = 0.278013851 N:

    sigma_fxy = 0.20 ozf = 0.0556 N,   sigma_fz = 0.40 ozf = 0.1112 N.

The thesis gives no torque figure.  We take 1/40 lbf.in = 0.002825 N.m, the torque resolution
that goes with a 1/80 lbf (= 0.20 oz) force resolution in ATI's small sensors (an assumption,
stated).  "Accurate to" is modelled as a Gaussian standard deviation.

The sampling gate "x-y force greater than 5 units" is read as 5 ozf = 1.39 N (the unit of
the accuracy figures); ``GATE_COUNTS_N`` is the other reading, 5 counts of 1/80 lbf = 0.278 N.
"""

import numpy as np

__all__ = [
    "OZF",
    "SIGMA_F",
    "SIGMA_M",
    "GATE_N",
    "GATE_COUNTS_N",
    "add_noise",
]

OZF = 0.27801385095378  # N per ounce-force (avoirdupois)
LBF = 16.0 * OZF
INCH = 0.0254
SIGMA_F = np.array([0.20, 0.20, 0.40]) * OZF  # N, (x, y, z)
SIGMA_M = np.full(3, LBF * INCH / 40.0)  # N.m, assumed (see above)
GATE_N = 5.0 * OZF
GATE_COUNTS_N = 5.0 * LBF / 80.0


def add_noise(force, moment, rng, sigma_f=SIGMA_F, sigma_m=SIGMA_M):
    """Force and moment with independent Gaussian noise per axis (None rng: no noise)."""
    if rng is None:
        return np.asarray(force, float), np.asarray(moment, float)
    F = np.asarray(force, float)
    M = np.asarray(moment, float)
    return (
        F + rng.standard_normal(F.shape) * np.asarray(sigma_f),
        M + rng.standard_normal(M.shape) * np.asarray(sigma_m),
    )
