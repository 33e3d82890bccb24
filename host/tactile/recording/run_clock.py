"""A recording's own time: seconds since it started that never go back, and the host's stalls.

``record`` reads its board in a loop whose turns take a read timeout and a few writes: tens
of milliseconds.  A turn much longer than that is not the board's doing: the host stood
still (Ctrl-Z then ``fg``, a paused VM, a disk that took seconds to write).  The board went
on meanwhile, and what it sent waits on the port (or was dropped by the board, which its
sequence numbers and STATUS ``tx_dropped`` say).  ``RunClock`` tells the loop so, and the
loop reads what waits before it judges anything by the clock (``tactile.recording.session``).

The host's monotonic clock may also step back (a VM restored or migrated): ``elapsed()``
adds only the forward steps, so it never goes back and never goes below 0, and a step back
is reported as a stall too.
"""

import time

STALL_S = 1.0  # a loop turn this long (host seconds) means the host stood still


class RunClock:
    """Elapsed seconds on ``clock`` (any monotonic-ish callable), and the stalls seen.

    ``elapsed()`` reads the clock; ``stall()`` returns (and forgets) the largest step seen
    between two readings beyond ``stall_s`` (or below 0), or None; ``waited()`` forgets it
    too, after a wait the caller made on purpose (a handshake, a TARE, a reconnection).
    """

    def __init__(self, clock=time.monotonic, stall_s=STALL_S):
        self.clock = clock
        self.stall_s = stall_s
        self._at = None  # the clock's latest reading
        self._elapsed = 0.0
        self._stall = None  # the step of an unreported stall

    def start(self):
        self._at, self._elapsed, self._stall = self.clock(), 0.0, None

    def elapsed(self):
        """Seconds since ``start()``: the sum of the clock's forward steps."""
        if self._at is None:
            return 0.0
        now = self.clock()
        step = now - self._at
        self._at = now
        if not 0.0 <= step <= self.stall_s and (
            self._stall is None or abs(step) > abs(self._stall)
        ):
            self._stall = step
        self._elapsed += max(0.0, step)
        return self._elapsed

    def stall(self):
        """The clock's step over the latest stall (s; negative: it went back), or None."""
        self.elapsed()
        step, self._stall = self._stall, None
        return step

    def waited(self):
        """The time since the last reading was a wait the caller made: not a stall."""
        self.elapsed()
        self._stall = None


def stall_words(pause):
    """One line for the user about a stall (an entry of meta.json's ``pauses``)."""
    at, step, read = pause["at_s"], pause["clock_step_s"], pause["bytes_waiting"]
    if step < 0:
        what = f"the host's clock stepped back {-step:.1f} s at {at:.1f} s (elapsed time goes on)"
    else:
        what = f"the host stood still for {step:.1f} s at {at:.1f} s (suspended? a slow disk?)"
    return f"{what}; read the {read:,} bytes that waited on the port; recording goes on"
