"""The F/T transducer seen by the ADCs: wrench -> six gauge signals (thesis ch. 5).

Gauges respond linearly to the wrench, ``g = A w + bias + drift t + D(t) + noise``
(counts), and the board's calibration is ``C = A^-1`` (ATI's convention
F/T = C (g - bias)).  ``w`` includes the tool's weight (``tool_weight``); ``D`` is the
random walk and temperature effect (``gauge_drift``), absent unless the scene asks.
``A`` mixes every axis into every gauge like a real six-gauge transducer, with
sensitivities chosen so that full-scale load reaches 60% of the converter's range.  Noise
is specified in wrench units (the thesis's sensor: 0.20 ozf in x and y, 0.40 ozf in z) and
mapped through ``A``; a noiseless model draws no random numbers.
"""

import numpy as np

FULL_SCALE_CODE = 0.6 * (1 << 23)
VOLTS_PER_COUNT = 3.07e-9  # the gauge volts of one count: 3.3 V / (128 x 2^23), docs/calibration.md
NOISE_BLOCK = 256  # instants of noise drawn at once: the same stream as one draw per instant


def sensitivity_matrix(force_range_n, torque_range_nm):
    """A (counts per N or N*m): an orthogonal mixing times per-axis sensitivities."""
    h = np.array(
        [
            [1, 1, 1, 1, 1, 1],
            [1, -1, 1, -1, 1, -1],
            [1, 1, -1, -1, 1, 1],
            [1, -1, -1, 1, 1, -1],
            [1, 1, 1, 1, -1, -1],
            [1, -1, 1, -1, -1, 1],
        ],
        dtype=float,
    )
    q, _ = np.linalg.qr(h + 0.3 * np.eye(6))  # well conditioned, every gauge sees every axis
    per_axis = np.array([force_range_n] * 3 + [torque_range_nm] * 3)
    return q * (FULL_SCALE_CODE / per_axis)


def per_volt_matrix(sensor):
    """The transducer's calibration as its maker ships it: N and N*m per gauge volt
    (``VOLTS_PER_COUNT`` volts a count), the matrix the emulated board holds."""
    return np.linalg.inv(sensitivity_matrix(sensor["force_range_N"], sensor["torque_range_Nm"])) / (
        VOLTS_PER_COUNT
    )


class FTModel:
    """Gauge counts for a wrench trajectory; one instance per sensor."""

    def __init__(self, sensor, wrench_at, seed=0, drift=None):
        self.A = sensitivity_matrix(sensor["force_range_N"], sensor["torque_range_Nm"])
        self.C = np.linalg.inv(self.A)
        self.bias = np.broadcast_to(np.asarray(sensor["bias_counts"], float), (6,)).copy()
        d = sensor["drift_counts_per_s"]  # one for all gauges (a float) or one each
        self.drift = np.asarray(d, float) if isinstance(d, list) else float(d)
        self.more_drift = drift  # a gauge_drift.GaugeDrift, or None
        sigma = np.array(list(sensor["noise_force_N"]) + list(sensor["noise_torque_Nm"]), float)
        self.sigma = sigma
        self.rng = np.random.default_rng(seed) if np.any(sigma > 0) else None
        self.wrench_at = wrench_at
        self.saturation = None  # None, +1 or -1: force gauges to a rail (fault injection)
        self._t = None
        self._g = np.zeros(6)
        self._values = [0.0] * 6
        self._noise = np.zeros((0, 6))  # drawn ahead, already times sigma; row _k is next
        self._k = 0

    def _at(self, t_us):
        w = np.asarray(self.wrench_at(t_us * 1e-6), float)
        if self.rng is not None:
            if self._k == len(self._noise):
                self._noise = self.rng.normal(0.0, 1.0, (NOISE_BLOCK, 6)) * self.sigma
                self._k = 0
            w = self._noise[self._k] + w  # (IEEE addition commutes: the same sums as w + noise)
            self._k += 1
        g = self.A.dot(w)  # A @ w, without the ufunc dispatch
        g += self.bias
        if np.any(self.drift):  # (adding 0.0 could only turn a -0.0 into 0.0: the same code)
            g += self.drift * t_us * 1e-6
        if self.more_drift is not None:
            g += self.more_drift.counts(t_us)
        self._g = g
        self._values = self._g.tolist()
        self._t = t_us

    def gauges(self, t_us):
        """The six gauge counts (float) at simulated time ``t_us``; cached per instant."""
        if t_us != self._t:
            self._at(t_us)
        return self._g

    def gauge_values(self, t_us):
        """``gauges(t_us)`` as a list of Python floats: the same values, cheaper to index.

        The six converters of a sensor read the same instant, so the wrench, the noise
        draw and the mixing run once per conversion, not once per gauge.
        """
        if t_us != self._t:
            self._at(t_us)
        return self._values

    def calibration_coefficients(self):
        """C row-major, the 36 float32 coefficients the board stores (N per count)."""
        return [float(np.float32(v)) for v in self.C.ravel()]
