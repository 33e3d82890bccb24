"""Sample scheduling on MicroPython's wrapping tick counter.

The clock is injected: on a board it is the ``time`` module (``ticks_us``,
``ticks_diff``, ``ticks_add``, ``sleep_us``); under CPython and in the
emulator it is an object with the same four methods, e.g. ``ManualClock``
(simulated time that only moves when told).  Ticks wrap at 2**30 as on
MicroPython, so the wrap is exercised under CPython too.
"""

from tactile_protocol.constants import const

TICKS_PERIOD = const(1 << 30)
TICKS_MAX = const((1 << 30) - 1)
TICKS_HALF = const(1 << 29)


class ManualClock:
    """Simulated microsecond clock with MicroPython's tick arithmetic."""

    def __init__(self, t_us=0):
        self.t_us = t_us  # unbounded simulated time

    def ticks_us(self):
        return self.t_us & TICKS_MAX

    def ticks_diff(self, a, b):
        return ((a - b + TICKS_HALF) & TICKS_MAX) - TICKS_HALF

    def ticks_add(self, a, d):
        return (a + d) & TICKS_MAX

    def sleep_us(self, d):
        if d > 0:
            self.t_us += d

    advance = sleep_us


class Scheduler:
    """Fixed-period deadlines; a tick taken a full period late is an overrun.

    ``check(now)`` returns -1 when no sample is due, else the number of whole
    periods missed (0: on time).  Missed slots are skipped, keeping the phase.
    """

    def __init__(self, clock, period_us):
        self.clock = clock
        self.period_us = period_us
        self.due = 0
        self.overruns = 0

    def start(self, now):
        self.due = self.clock.ticks_add(now, self.period_us)

    def set_period(self, period_us, now):
        self.period_us = period_us
        self.start(now)

    def until_due(self, now):
        return self.clock.ticks_diff(self.due, now)

    def check(self, now):
        clock = self.clock
        late = clock.ticks_diff(now, self.due)
        if late < 0:
            return -1
        period = self.period_us
        missed = late // period
        self.due = clock.ticks_add(self.due, (missed + 1) * period)
        if missed:
            self.overruns += missed
        return missed
