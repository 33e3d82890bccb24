"""A sensor's readings averaged within each hold of a pose log, for ``identify``.

Each window of the log is a hold: the robot keeps the unloaded finger still at one pose.
Its edges are trimmed (``trim``, a fraction of the window at each end: the arm settling,
a log's stamps a little off), and the readings left are averaged.  A hold with fewer than
``min_readings`` readings left is dropped, and said so.

A board streaming both SAMPLE and CONTACT frames sends each reading in contact twice; the
readings of a sensor are its SAMPLE frames when it has any, else its CONTACT frames
(``reading_rows``).
"""

from dataclasses import dataclass, field

import numpy as np

__all__ = ["MIN_READINGS", "TRIM", "Holds", "hold_means", "reading_rows"]

TRIM = 0.2  # of each window, at each end
MIN_READINGS = 5


@dataclass
class Holds:
    """Per kept hold: ``R`` (k, 3, 3), mean force ``F`` (k, 3) N and torque ``T`` (k, 3) N*m,
    ``count`` (k,) readings averaged, ``sd`` (k, 6) their standard deviations, ``lines`` the
    log's line of each; ``dropped`` [(line, why)] of the holds left out."""

    R: np.ndarray
    F: np.ndarray
    T: np.ndarray
    count: np.ndarray
    sd: np.ndarray
    lines: list
    dropped: list = field(default_factory=list)

    def __len__(self):
        return len(self.count)


def reading_rows(sensor, is_sample, s):
    """Indices of sensor ``s``'s readings among frames of ``sensor`` (n,) and ``is_sample``
    (n,) bool (SAMPLE, else CONTACT): its SAMPLE frames if it has any, else its CONTACT ones."""
    mine = np.asarray(sensor) == s
    samples = mine & np.asarray(is_sample, dtype=bool)
    return np.flatnonzero(samples if samples.any() else mine)


def hold_means(t_us, wrench, t_start, t_end, R, lines, trim=TRIM, min_readings=MIN_READINGS):
    """``Holds`` of readings at ``t_us`` (n,) with ``wrench`` (n, 6) (one sensor's, in the
    log's clock) over windows ``t_start``, ``t_end`` (k,) held at ``R`` (k, 3, 3)."""
    if not 0 <= trim < 0.5:
        raise ValueError(f"trim: {trim!r} is not a fraction of a window in [0, 0.5)")
    t = np.asarray(t_us, dtype=np.int64)
    W = np.asarray(wrench, dtype=float).reshape(-1, 6)
    order = np.argsort(t, kind="stable")
    ts = t[order]
    keep, means, sds, counts, dropped = [], [], [], [], []
    for i, (a, b) in enumerate(zip(np.asarray(t_start), np.asarray(t_end))):
        cut = trim * (b - a)
        lo = np.searchsorted(ts, a + cut, side="left")
        hi = np.searchsorted(ts, b - cut, side="right")
        rows = order[lo:hi]
        if len(rows) < min_readings:
            dropped.append(
                (lines[i], f"{len(rows)} readings in the hold (fewer than {min_readings})")
            )
            continue
        keep.append(i)
        means.append(W[rows].mean(axis=0))
        sds.append(W[rows].std(axis=0))
        counts.append(len(rows))
    mean = np.array(means).reshape(-1, 6)
    return Holds(
        R=np.asarray(R, dtype=float)[keep].reshape(-1, 3, 3),
        F=mean[:, :3],
        T=mean[:, 3:],
        count=np.array(counts, dtype=int),
        sd=np.array(sds).reshape(-1, 6),
        lines=[lines[i] for i in keep],
        dropped=dropped,
    )
