"""The bias of a sensor carrying a tool: taken on the host, then tracked between contacts.

The tracker sees x = reading - weight(R): what the sensor reads less the tool's weight at
that reading's orientation, which out of contact is the bias alone.  Readings are grouped
in blocks of ``BLOCK_S`` (by the reading's time); a block's mean is *steady* when it differs
from the block before by at most ``STEADY_SIGMAS`` of their standard errors plus
``STEADY_FLOOR``, on every axis.

- **Tare** (no bias yet): the first ``TARE_BLOCKS`` steady blocks in a row give the bias,
  their mean: the reading less the tool's weight at each reading's orientation, so at any
  pose (a TARE of the board takes the whole reading, right at one orientation only).  A run
  must start with the finger free, as a TARE does.
- **Tracking**: a steady block whose every reading is *quiet* (the caller's word: out of
  contact by the gate, |F| well below the exit level, not just after a contact) moves the
  bias toward its mean as a first-order filter of time constant ``TAU_S``, and by at most
  ``MAX_RATE_N_S`` (force, as a vector) and ``MAX_RATE_NM_S`` (torque) times the time since
  the last move.  A block with any reading in contact never moves it, so a press, however
  long, is never taken for drift; a load below the gate moves it no faster than the bound.

Choices, for the drift this is for (gauges drifting 0.02 N/min, 3.3e-4 N/s, with a sensor's
noise of ~0.05 N per reading at 0.5-1 kHz): a block of 0.1 s averages ~100 readings (5 mN);
``TAU_S`` = 2 s makes the filter's own noise ~1 mN and lags a 0.02 N/min drift by 0.7 mN
when the finger is free a third of the time (lag = rate x tau / fraction free, 2 mN); the
bound, 0.005 N/s (0.3 N/min, 15 times that drift), lets a temperature step through in
seconds while a 1 N load under the gate would take minutes to absorb.

Each tare and each run of moves between two contacts is one entry of ``log`` (times in s of
the readings' clock, biases in N and N*m): what meta.json records.
"""

import numpy as np

__all__ = ["BLOCK_S", "MAX_RATE_N_S", "MAX_RATE_NM_S", "TAU_S", "BiasTracker"]

BLOCK_S = 0.1
TAU_S = 2.0
MAX_RATE_N_S = 0.005
MAX_RATE_NM_S = 0.00025  # the force bound times 5 cm
TARE_BLOCKS = 3
STEADY_SIGMAS = 4.0
STEADY_FLOOR = np.array([2e-3] * 3 + [1e-4] * 3)  # N, N*m
MIN_BLOCK = 5  # readings in a block that may move the bias
DIGITS = 9  # significant digits of a bias in the log


def _rounded(v):
    return [float(f"{x:.{DIGITS}g}") for x in np.asarray(v, dtype=float)]


class _Block:
    """Sums of one block's readings."""

    def __init__(self, index, t):
        self.index, self.t0, self.t1 = index, t, t
        self.n, self.sum, self.sumsq, self.quiet = 0, np.zeros(6), np.zeros(6), True

    def add(self, t, x, quiet):
        self.t1 = float(t[-1])
        self.n += len(x)
        self.sum += x.sum(axis=0)
        self.sumsq += (x * x).sum(axis=0)
        self.quiet &= bool(np.all(quiet))

    def stats(self):
        mean = self.sum / self.n
        var = np.maximum(self.sumsq / self.n - mean * mean, 0.0)
        return mean, np.sqrt(var / self.n)


class BiasTracker:
    """Tare and drift tracking of one sensor's bias (module docstring); ``bias`` (6,) or None
    before the tare; ``log`` the entries for meta.json."""

    def __init__(self, bias=None, tau_s=TAU_S, max_rate=(MAX_RATE_N_S, MAX_RATE_NM_S)):
        self.bias = None if bias is None else np.asarray(bias, dtype=float).reshape(6).copy()
        self.tau_s, self.max_rate = float(tau_s), tuple(max_rate)
        self.log = []
        self.moves = 0
        self._block = None
        self._prev = None  # (index, mean, se, n, t0) of the block before
        self._tare = []  # (n, mean, t0, t1) of the steady blocks in a row
        self._moved_at = None  # time of the last move (or the tare)
        self._run = None  # the log entry of the moves since the last contact

    def advance(self, t_s):
        """Close the block being filled if ``t_s`` (s) is in another: the bias a reading at
        ``t_s`` gets is then the same however the readings were batched."""
        index = int(np.floor(t_s / BLOCK_S))
        if self._block is not None and self._block.index != index:
            self._close(index < self._block.index)

    def add(self, t_s, x, quiet):
        """Feed readings at times ``t_s`` (k,) s, ``x`` (k, 6) reading less weight, ``quiet``
        (k,) bool; the bias may move as each block closes."""
        t_s = np.asarray(t_s, dtype=float)
        if not len(t_s):
            return
        index = np.floor(t_s / BLOCK_S).astype(np.int64)
        cuts = np.flatnonzero(np.diff(index)) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(t_s)]):
            if self._block is not None and self._block.index != index[a]:
                self._close(index[a] < self._block.index)
            if self._block is None:
                self._block = _Block(index[a], float(t_s[a]))
            self._block.add(t_s[a:b], x[a:b], quiet[a:b])

    def flush(self):
        """Close the block being filled (the end of the readings)."""
        if self._block is not None:
            self._close(False)

    def _close(self, back):
        block, self._block = self._block, None
        if back:  # time stepped back (a reboot, a wrap): start over, keep the bias
            self._prev, self._tare = None, []
            return
        mean, se = block.stats()
        prev, self._prev = self._prev, (block.index, mean, se, block.n, block.t0)
        steady = prev is not None and prev[0] == block.index - 1
        if steady:
            allowed = STEADY_SIGMAS * np.hypot(se, prev[2]) + STEADY_FLOOR
            steady = bool(np.all(np.abs(mean - prev[1]) <= allowed))
        if self.bias is None:
            self._taring(block, mean, prev, steady)
        elif steady and block.quiet and block.n >= MIN_BLOCK:
            self._move(block, mean)
        else:
            self._run = None

    def _taring(self, block, mean, prev, steady):
        if not steady:
            self._tare = []
            return
        if not self._tare:
            self._tare.append((prev[3], prev[1], prev[4], block.t0))  # the block before
        self._tare.append((block.n, mean, block.t0, block.t1))
        if len(self._tare) >= TARE_BLOCKS:
            n = np.array([k[0] for k in self._tare], dtype=float)
            self.bias = np.average([k[1] for k in self._tare], axis=0, weights=n)
            self._moved_at = block.t1
            self.log.append(
                {"tare_at_s": round(self._tare[0][2], 6), "until_s": round(block.t1, 6),
                 "bias": _rounded(self.bias)}
            )  # fmt: skip
            self._tare = []

    def _move(self, block, mean):
        dt = max(block.t1 - self._moved_at, 0.0) if self._moved_at is not None else BLOCK_S
        alpha = 1.0 - np.exp(-BLOCK_S / self.tau_s)
        step = alpha * (mean - self.bias)
        for part, rate in ((slice(0, 3), self.max_rate[0]), (slice(3, 6), self.max_rate[1])):
            size = np.linalg.norm(step[part])
            if size > rate * dt:
                step[part] *= rate * dt / size
        before = self.bias.copy()
        self.bias = self.bias + step
        self._moved_at = block.t1
        self.moves += 1
        if self._run is None:
            self._run = {"from_s": round(block.t0, 6), "to_s": 0.0, "moves": 0,
                         "bias_before": _rounded(before), "bias_after": None}  # fmt: skip
            self.log.append(self._run)
        self._run.update(to_s=round(block.t1, 6), moves=self._run["moves"] + 1)
        self._run["bias_after"] = _rounded(self.bias)
