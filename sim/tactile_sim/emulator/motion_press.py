"""``kind = "press"``: a wrench given directly as keyframes, linearly interpolated.

For protocol and gate tests: ``keyframes = [[t_s, fx, fy, fz, tx, ty, tz], ...]``
(N and N*m, times increasing).  Before the first and after the last keyframe
the wrench holds.  ``repeat = true`` loops the keyframes over their span.
"""

import bisect

import numpy as np


class PressMotion:
    def __init__(self, keyframes, repeat=False):
        self.t = keyframes[:, 0]
        self.w = keyframes[:, 1:]
        self.repeat = repeat
        self.span = float(self.t[-1] - self.t[0]) if len(self.t) > 1 else 0.0
        self._ts = self.t.tolist()
        self._rows = self.w.tolist()

    def wrench_at(self, t_s, sensor=0):
        """Wrench at time ``t_s`` (a scalar, or an array giving a (6, n) array)."""
        if self.repeat and self.span > 0:
            t_s = self.t[0] + (t_s - self.t[0]) % self.span
        if isinstance(t_s, float):  # (np.float64 too) the emulator's case: np.interp's arithmetic
            return np.array(self._at(float(t_s)))
        return np.array([np.interp(t_s, self.t, self.w[:, k]) for k in range(6)])

    def orientation_at(self, t_s, sensor=0):
        """The sensor's frame is the world's: a press has no robot to turn it."""
        return np.eye(3)

    def _at(self, x):
        ts, rows = self._ts, self._rows
        if x <= ts[0]:
            return rows[0]
        if x >= ts[-1]:
            return rows[-1]
        j = bisect.bisect_right(ts, x) - 1
        dt = ts[j + 1] - ts[j]
        out = []
        for a, b in zip(rows[j], rows[j + 1]):
            slope = (b - a) / dt
            v = slope * (x - ts[j]) + a
            if v != v:  # nan, as np.interp retries from the right end
                v = slope * (x - ts[j + 1]) + b
                if v != v and a == b:
                    v = a
            out.append(v)
        return out


def build(scene):
    """The press motion of ``scene`` (keyframes checked by ``scene_schema``)."""
    m = scene.motion
    return PressMotion(np.asarray(m["keyframes"], dtype=float), m["repeat"])
