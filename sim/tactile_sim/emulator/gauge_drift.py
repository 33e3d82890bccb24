"""The gauges' drift beyond the linear one: a random walk and a temperature effect.

Per gauge j, in counts (docs/emulator.md):

    D_j(t) = W_j(t) + k_j (T(t) - T(t_0))

- W_j: a random walk with W_j(0) = 0 and independent Gaussian steps of sd s_j sqrt(h) every
  ``STEP_S`` = h of scene time, linear in between (``[sensor] bias_walk_counts_per_sqrt_s`` =
  s_j).  The steps come in blocks of ``BLOCK``, each from its own generator seeded by the
  scene's seed, the sensor's index and the block's: W at an instant depends on the instant
  only, not on when or how often the converters ask, and memory holds one block and six
  numbers per block before it (a day of scene time: 100 kB).
- T(t): ``[sensor] temperature_C`` keyframes (t_s, C), linear in between and held outside,
  T(t_0) the first keyframe's temperature; k_j = ``bias_counts_per_C``.

The linear drift (``drift_counts_per_s``) stays in ``ft_model``, where it always was.  A scene
with neither walk nor temperature builds no ``GaugeDrift`` (``from_sensor`` is None).
"""

import numpy as np

__all__ = ["GaugeDrift", "STEP_S"]

STEP_S = 0.01  # the walk's step (s)
BLOCK = 4096  # steps drawn at once (41 s of scene time)
STREAM = 0x5EED_D21F  # the walk's generator, apart from the noise's


def _per_gauge(value):
    return np.broadcast_to(np.asarray(value, float), (6,)).copy()


class GaugeDrift:
    def __init__(self, walk, temperature, per_c, seed=0, sensor=0):
        self.walk = _per_gauge(walk)
        self.seed, self.sensor = seed, sensor
        self._starts, self._block, self._w = [np.zeros(6)], None, None
        keys = np.asarray(temperature, float).reshape(-1, 2)
        self.per_c = _per_gauge(per_c)
        self.temperature = keys if len(keys) and self.per_c.any() else None

    @classmethod
    def from_sensor(cls, sensor, seed, index):
        """The ``[sensor]`` section's walk and temperature effect, or None if it has neither."""
        walk, keys = sensor["bias_walk_counts_per_sqrt_s"], sensor["temperature_C"]
        per_c = sensor["bias_counts_per_C"]
        if not np.any(walk) and not (keys and np.any(per_c)):
            return None
        return cls(walk, keys, per_c, seed, index)

    def _steps(self, b):
        """W over block b's steps, from 0: (BLOCK + 1, 6), its own generator per block."""
        rng = np.random.default_rng([STREAM, self.seed, self.sensor, b])
        steps = rng.normal(0.0, 1.0, (BLOCK, 6)) * (self.walk * np.sqrt(STEP_S))
        return np.vstack([np.zeros((1, 6)), np.cumsum(steps, axis=0)])

    def _walk(self, t_s):
        x = max(t_s, 0.0) / STEP_S
        b, k = divmod(int(x), BLOCK)
        if b != self._block:
            while len(self._starts) <= b:  # W at each block's start (6 numbers a block)
                self._starts.append(self._starts[-1] + self._steps(len(self._starts) - 1)[-1])
            self._w, self._block = self._starts[b] + self._steps(b), b
        f = x - (b * BLOCK + k)
        return (1.0 - f) * self._w[k] + f * self._w[k + 1]

    def temperature_at(self, t_s):
        """The sensor's temperature (degC) at ``t_s``; None without keyframes."""
        if self.temperature is None:
            return None
        return float(np.interp(t_s, self.temperature[:, 0], self.temperature[:, 1]))

    def counts(self, t_us):
        """D (6,) in counts at scene time ``t_us``."""
        t_s = t_us * 1e-6
        out = self._walk(t_s) if self.walk.any() else np.zeros(6)
        if self.temperature is not None:
            out = out + self.per_c * (self.temperature_at(t_s) - self.temperature[0, 1])
        return out
