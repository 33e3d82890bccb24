"""Board clock -> host clock: a line fitted under the arrival times of frames.

A frame the board stamps ``b`` (its own clock, s) reaches the host at
``h = offset + rate * b + d``: ``rate`` is 1 plus the two crystals' relative drift (tens of
ppm), and the delay ``d`` (USB polling, the OS, a busy reader) is never negative.  So the
points ``(b, h)`` lie on or above the line ``offset + rate * b``, and that line is what the
fit looks for, from below (the one-way clock estimate of Moon, Skelly and Towsley, 1999):

1. ``BinMinima``: the board time is cut into bins (``bin_s``, 0.1 s) and each bin keeps the
   frame that waited least (least ``h - b``) plus the count, sum and largest of ``h - b``.
   At most ``max_bins`` are kept: beyond that, neighbours merge and the width doubles.
   The bin's minimum is chosen with slope 1 in place of ``rate``, which costs at most
   ``|rate - 1| * bin width`` (5 us at 50 ppm and 0.1 s).
2. ``fit``: the ``tau``-quantile line through the bin minima, by linear programming (Koenker
   and Bassett's quantile regression in its bounded dual form; HiGHS through scipy).  With
   fewer than ``1 / tau`` bins that is the lower envelope: no bin below the line.  With more,
   a fraction ``tau`` may lie below, so a few early outliers (a host clock that stepped, a
   frame stamped wrongly) cannot drag it down.

The constant part of the delay (the least latency any frame had) is inseparable from the
offset: ``to_host(b)`` is when the host could have first heard of ``b``.  Pure: numpy and
scipy only, no I/O, no protocol.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["BinMinima", "ClockFit", "fit", "TAU", "BIN_S", "MAX_BINS"]

TAU = 0.05  # quantile of the bin minima the line passes
BIN_S = 0.1  # board seconds per bin at first
MAX_BINS = 2048  # beyond this, bins pair up (a fit of 2048 points takes ~50 ms)
EDGE = 1e-9  # bin widths: how near a bin's edge a frame counts as on it


class BinMinima:
    """Per bin of board time: the point of least ``h - b``; the count, the sums of ``b`` and of
    ``h - b``, and the point of greatest ``h - b``.

    ``add(b, h)`` takes one frame (board s, host s); board times may come in any order.
    """

    def __init__(self, bin_s=BIN_S, max_bins=MAX_BINS):
        if not bin_s > 0 or max_bins < 2:
            raise ValueError("bin_s must be > 0 and max_bins >= 2")
        self.width = float(bin_s)
        self.max_bins = int(max_bins)
        self.origin = None  # board time of bin 0's start
        # index -> [b at min, h at min, count, sum(b), sum(h - b), b at max, max(h - b)]
        self.bins = {}

    def __len__(self):
        return len(self.bins)

    def add(self, b, h):
        if self.origin is None:
            self.origin = b
        # a frame on a bin's edge (a stream at the bin rate) goes to the bin it opens,
        # whichever frame set the origin: round-off in b - origin must not pair two frames
        k = int(np.floor((b - self.origin) / self.width + EDGE))
        lag = h - b
        cell = self.bins.get(k)
        if cell is None:
            self.bins[k] = [b, h, 1, b, lag, b, lag]
            if len(self.bins) > self.max_bins:
                self._merge()
            return
        self._join(cell, [b, h, 1, b, lag, b, lag])

    @staticmethod
    def _join(cell, other):
        if other[1] - other[0] < cell[1] - cell[0]:
            cell[0], cell[1] = other[0], other[1]
        cell[2] += other[2]
        cell[3] += other[3]
        cell[4] += other[4]
        if other[6] > cell[6]:
            cell[5], cell[6] = other[5], other[6]

    def _merge(self):
        """Pair up neighbouring bins (width doubles) until at most ``max_bins`` remain."""
        while len(self.bins) > self.max_bins:
            self.width *= 2.0
            merged = {}
            for k in sorted(self.bins):
                cell, into = self.bins[k], merged.get(k // 2)
                if into is None:
                    merged[k // 2] = list(cell)
                else:
                    self._join(into, cell)
            self.bins = merged

    def arrays(self):
        """(b at min, h at min, count, sum of b, sum of h - b, b at max, max of h - b) per
        bin, in board order."""
        if not self.bins:
            return tuple(np.zeros(0) for _ in range(7))
        a = np.array([self.bins[k] for k in sorted(self.bins)], dtype=float)
        return tuple(a.T)


@dataclass(frozen=True)
class ClockFit:
    """``host = host0_s + rate * (board - board0_s)``, fitted to ``bins`` bin minima.

    ``floor_s``: median distance of the bin minima above the line (how well the envelope is
    pinned: small when many frames arrive promptly); ``delay_mean_s``, ``delay_max_s``:
    how late the frames arrived, on average and at worst, after the line.
    """

    board0_s: float
    host0_s: float
    rate: float
    bins: int
    frames: int
    floor_s: float
    delay_mean_s: float
    delay_max_s: float

    @property
    def drift_ppm(self):
        return (self.rate - 1.0) * 1e6

    def to_host(self, board_s):
        return self.host0_s + self.rate * (np.asarray(board_s, dtype=float) - self.board0_s)

    def to_board(self, host_s):
        return self.board0_s + (np.asarray(host_s, dtype=float) - self.host0_s) / self.rate


def _quantile_line(x, y, tau):
    """(a, b) of the tau-quantile line y = a + b x (x centred and scaled by the caller)."""
    from scipy.optimize import linprog

    X = np.column_stack([np.ones_like(x), x])
    # Dual of min sum rho_tau(y - X beta): max y'd s.t. X'd = (1 - tau) X'1, 0 <= d <= 1;
    # beta is minus the equality constraints' marginals.
    r = linprog(-y, A_eq=X.T, b_eq=(1.0 - tau) * X.sum(axis=0), bounds=(0.0, 1.0), method="highs")
    if r.status != 0:  # not expected for finite data; the envelope's lowest point is a fallback
        k = int(np.argmin(y))
        return float(y[k]), 0.0
    a, b = -np.asarray(r.eqlin.marginals, dtype=float)
    return float(a), float(b)


def fit(bins, tau=TAU):
    """The ``ClockFit`` of a ``BinMinima`` (None when it holds nothing).

    One bin: rate 1 through its minimum.  Otherwise the tau-quantile line of the minima, in
    coordinates centred on their mean and scaled by their spread, fitted to ``h - b`` (the
    offset plus delay, which varies by ppm) so that nothing large is subtracted.
    """
    if not 0.0 < tau < 0.5:
        raise ValueError("tau must be in (0, 0.5)")
    b, h, count, b_sum, lag_sum, b_max, lag_max = bins.arrays()
    if len(b) == 0:
        return None
    lag = h - b
    b0 = float(np.mean(b))
    if len(b) == 1 or np.ptp(b) == 0.0:
        a, slope = float(np.min(lag)), 0.0
    else:
        scale = float(np.ptp(b))
        a, s = _quantile_line((b - b0) / scale, lag - np.mean(lag), tau)
        a += float(np.mean(lag))
        slope = s / scale
    line = a + slope * (b - b0)  # the fitted h - b at each bin's minimum
    above = lag - line
    n = float(np.sum(count))
    line_sum = a * count + slope * (b_sum - b0 * count)  # sum of the line over each bin
    return ClockFit(
        board0_s=b0,
        host0_s=b0 + a,
        rate=1.0 + slope,
        bins=len(b),
        frames=int(n),
        floor_s=float(np.median(above)),
        delay_mean_s=float(np.sum(lag_sum - line_sum) / n),
        delay_max_s=float(np.max(lag_max - (a + slope * (b_max - b0)))),
    )
