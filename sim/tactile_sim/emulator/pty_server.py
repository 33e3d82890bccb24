"""The in-process cores (``python``, ``c``) on a pty, in real time or as fast as possible.

``PtyServer`` steps an ``EmulatedBoard`` (the firmware on simulated time) for ``Server``,
which owns the pty, host presence, hold, drain, keep and drop (``server``).  The board is
told when a host is announced (it answers with HELLO); while nobody reads, its writes find
no reader and the firmware drops and counts frames, as on USB.  A scene's ``[link]
disconnect`` window closes the pty and opens a new one, behind the same ``--link``: a cable
pulled and plugged back; as fast as possible the host first reads what is in flight.

As fast as possible (``realtime=False``), simulated time runs in ticks of ``FAST_TICK_S`` and
holds until a host is announced (so it sees the scene from its start) and while the pty is
full.  In real time it runs in ticks of ``TICK_S``, never ahead of the wall clock, and a
slow or absent host makes it drop frames, as a real board does.  An emulator more than
``BEHIND_S`` behind the wall clock (a loaded machine, a heavy scene) does what an overloaded
board does: the polls it had no time for are skipped, and the firmware counts the missed
periods as overruns and sets the sample-late flag on the next samples, so the host can tell.
"""

import time

from tactile_sim.emulator import pty_link
from tactile_sim.emulator.server import HOLD_BYTES, OPEN_SETTLE_S, Server

TICK_S = 0.002  # real time: simulated time per exchange with the host (bounds latency)
FAST_TICK_S = 0.02  # as fast as possible: fewer, larger writes and polls
FULL_WAIT_S = 0.0005  # as fast as possible, pty full: wait this long for the host to read
HOST_WAIT_S = 0.005  # as fast as possible, no host yet: look again after this long
BEHIND_S = 0.05  # real time: this far behind the wall clock, skip ahead (the samples are late)


class PtyServer(Server):
    """Run ``board`` (an ``EmulatedBoard`` of core ``python`` or ``c``) behind a pty.

    ``realtime`` may change while serving; ``reconnects`` counts the disconnect windows
    served, ``skipped`` the times the board fell ``BEHIND_S`` behind and skipped ahead.
    """

    SERVES_DISCONNECTS = True

    def __init__(self, board, link_path=None, realtime=True, faults=None, disconnects=(),
                 **options):  # fmt: skip
        super().__init__(board, link_path, realtime, faults, disconnects, **options)
        self.reconnects = 0
        self.skipped = 0
        self._waiting = False  # the last step held: wait for the host before the next
        self._start = None  # the wall clock when the board's time began

    # --- the core ---------------------------------------------------------------------------
    def start(self):
        self._start = self.clock()

    def opened(self):
        self.board.host_opened()

    def read(self):
        return self.board.read_host()

    def write(self, data):
        self.board.write_host(data)

    def tick(self):
        """After each step that ran the board (a subclass may end the run here)."""

    def wants_hold(self):
        return not self.realtime and (not self.endpoint.host_present or bool(self.to_host))

    def idle_s(self):
        if self.realtime and not self.draining:
            ahead = self._ahead()
            return min(ahead, OPEN_SETTLE_S / 2) if ahead > 0 else 0.0
        if self._waiting:  # (poll() returns at once while nobody has the pty open)
            return FULL_WAIT_S if self.endpoint.host_present else HOST_WAIT_S
        return 0.0

    def _ahead(self):
        return self.board.t_us / 1e6 - (self.clock() - self._start)

    def step(self, held):
        self._waiting = held
        board = self.board
        if self.draining:
            return True
        replug = self._unplugged(board.t_us)
        if replug is not None:
            if not self.realtime:
                self._let_host_read()
            self._disconnect(replug)
            return True
        if self.realtime:
            ahead = self._ahead()
            if ahead > 0:  # never run ahead of the wall clock
                return True
            if ahead < -BEHIND_S:  # behind: skip the polls there was no time for
                self._skip(board.t_us - int(ahead * 1e6))
        elif held:  # nobody there, or the last tick not taken: time holds
            return True
        target = board.t_us + int((TICK_S if self.realtime else FAST_TICK_S) * 1e6)
        for limit in (self.end_us, self._next_unplug(board.t_us)):
            if limit is not None:
                target = min(target, limit)
        # Bytes the pty did not take stay queued; beyond the pty's buffer the board's own
        # TxRing decides what to drop, as with a host that stops reading.
        board.set_host_reading(self.endpoint.host_present and len(self.to_host) < HOLD_BYTES)
        board.run_until(target)
        self.tick()
        return True

    def _skip(self, t_us):
        """Move the board's clock to ``t_us`` without polling (before an unplug or the end)."""
        for limit in (self.end_us, self._next_unplug(self.board.t_us)):
            if limit is not None:
                t_us = min(t_us, limit)
        self.board.skip_to(t_us)
        self.skipped += 1

    # --- the scene's disconnect windows (from the scene's start) ------------------------------
    def _windows(self):
        at = self.board.scene_start_us
        return [(a + at, b + at) for a, b in self.disconnects]

    def _unplugged(self, t_us):
        for a, b in self._windows():
            if a <= t_us < b:
                return b
        return None

    def _next_unplug(self, t_us):
        for a, _ in self._windows():
            if a > t_us:
                return a
        return None

    def _disconnect(self, until_us):
        """The cable is out until ``until_us``: the pty goes away, then a new one appears."""
        self.endpoint.close()
        if self.link_path:
            pty_link.remove(self.link_path)
        board = self.board
        board.set_host_reading(False)
        start, t0 = time.monotonic(), board.t_us
        while board.t_us < until_us and not self.stop:
            board.run_until(min(until_us, board.t_us + 2000))
            board.read_host()  # nothing leaves the board while unplugged
            if self.realtime:
                lag = (board.t_us - t0) / 1e6 - (time.monotonic() - start)
                if lag > 0:
                    time.sleep(lag)
        self.to_host.clear()
        self._present_since = None
        self._replugged = True  # the same session, back: not a new run of the scene
        self.open()
        self.reconnects += 1
