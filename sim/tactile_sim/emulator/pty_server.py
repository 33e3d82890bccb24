"""Serve an emulated board on a pseudo-terminal, paced in real time or as fast as possible.

The slave side is a real tty: the host opens its path with pyserial exactly
as it opens ``/dev/ttyACM0``.  A stable symlink (``--link``; ``pty_link`` makes it
only over an emulator's own link) points at the current slave, so a simulated
disconnect (the pty vanishes) and reconnect (a new pty) look like a cable pulled
and plugged back.  The master sees
``POLLHUP`` while no host has the slave open: the board's writes then find
no reader and the firmware drops and counts frames, as on USB; when a host
opens the port the firmware is told (it answers with HELLO), after a short
settle time: pyserial flushes the input buffer at the end of ``open()``, so a
HELLO written the instant the port opens would be discarded.

As fast as possible (``realtime=False``), simulated time runs in larger
ticks and only while a host is there to read: it holds until a host is
announced (so the host sees the scene from its start), while the pty is full,
and before a scripted unplug and the end of the run until the host has read
what is in flight (so a host that reads loses nothing the scene does not
take away); in a run with a duration, each for at most ``HOLD_LIMIT_S`` at a time: a
host that is gone or stopped reading for longer (or none, with ``--now``) does not stop
the run, which goes on and ends at its duration, the firmware dropping and counting what
nobody reads.  In
real time the board runs regardless and a slow or absent host makes it drop frames, as
a real board does.  An emulator that falls more than
``BEHIND_S`` behind the wall clock (a loaded machine, a heavy scene) does what
an overloaded board does: the polls it had no time for are skipped, its clock
catches up, and the firmware counts the missed periods as overruns and sets the
sample-late flag on the next samples, so the host can tell.
"""

import errno
import fcntl
import os
import select
import struct
import termios
import time
import tty

from tactile_protocol.errors import InputError
from tactile_sim.emulator import pty_link

OPEN_SETTLE_S = 0.05  # wait this long after the host opens before announcing
TICK_S = 0.002  # real time: simulated time per exchange with the host (bounds latency)
FAST_TICK_S = 0.02  # as fast as possible: fewer, larger writes and polls
FULL_WAIT_S = 0.0005  # as fast as possible, pty full: wait this long for the host to read
HOST_WAIT_S = 0.005  # as fast as possible, no host yet: look again after this long
DRAINED_S = 0.1  # ... the host has read all once the pty's input queue stays empty this long
BEHIND_S = 0.05  # real time: this far behind the wall clock, skip ahead (the samples are late)
HOLD_LIMIT_S = 3.0  # as fast as possible: hold for an absent or stalled host at most this long


class PtyEndpoint:
    """One pseudo-terminal; ``path`` is the slave device the host opens."""

    def __init__(self):
        self.master, slave = os.openpty()
        tty.setraw(slave)  # no echo or line editing even before the host configures it
        self.path = os.ttyname(slave)
        os.close(slave)
        os.set_blocking(self.master, False)
        self._poll = select.poll()
        self._poll.register(self.master, select.POLLIN | select.POLLHUP)
        self.host_present = False

    def wait(self, timeout_s):
        """Wait up to ``timeout_s`` for host input; return (readable, present).

        While no host has the slave open the master reports POLLHUP, at once and for as long
        as nobody opens it, so poll() cannot block then: the rest of the timeout is slept
        instead and presence looked at again, never spun on (an idle emulator waiting for a
        host took most of a core).  A host that opens the port is seen within ``timeout_s``.
        """
        deadline = time.monotonic() + max(0.0, timeout_s)
        readable, present = self._look(timeout_s)
        if not present and (left := deadline - time.monotonic()) > 0:
            time.sleep(left)
            readable, present = self._look(0.0)
        return readable, present

    def _look(self, timeout_s):
        events = self._poll.poll(max(0.0, timeout_s) * 1000)
        flags = 0
        for _, ev in events:
            flags |= ev
        present = not (flags & select.POLLHUP)
        return bool(flags & select.POLLIN) and present, present

    def read(self):
        try:
            return os.read(self.master, 4096)
        except OSError as exc:  # EIO: no host has the slave open
            if exc.errno in (errno.EIO, errno.EAGAIN):
                return b""
            raise

    def write(self, data):
        """Write what the pty takes now; return bytes accepted."""
        try:
            return os.write(self.master, data)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EIO):
                return 0
            raise

    def unread(self):
        """Bytes waiting in the slave's input queue (the part the kernel counts); 0 if unknown.

        Opens the slave briefly: only while a host has it open, so presence is unchanged.
        Up to ~16 kB more can wait in the pty's internal buffer until the host reads.
        """
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError:
            return 0
        try:
            return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]
        except OSError:
            return 0
        finally:
            os.close(fd)

    def close(self):
        os.close(self.master)


class HoldLimit:
    """As fast as possible: ``limit(want)`` says whether time may hold for the host now, for
    at most ``HOLD_LIMIT_S`` in a row (``want`` false ends a hold).  Only a run with an end
    (``bounded``) needs the limit: without one, holding for a host costs nothing."""

    def __init__(self, clock=time.monotonic):
        self.clock, self.since, self.bounded = clock, None, True

    def __call__(self, want):
        if not want:
            self.since = None
            return False
        now = self.clock()
        if self.since is None:
            self.since = now
        return not self.bounded or now - self.since < HOLD_LIMIT_S


class Stalled:
    """A host that takes nothing: ``stalled(state)`` turns true once ``state`` (what waits
    for the host) has not changed for ``HOLD_LIMIT_S``."""

    def __init__(self, clock=time.monotonic):
        self.clock, self.last, self.moved = clock, None, clock()

    def __call__(self, state):
        if state != self.last:
            self.last, self.moved = state, self.clock()
        return self.clock() - self.moved >= HOLD_LIMIT_S


class PtyServer:
    """Run ``board`` (an EmulatedBoard) behind a pty until ``stop`` or the duration."""

    def __init__(
        self, board, link_path=None, realtime=True, faults=None, disconnects=(), clock=None
    ):
        self.board = board
        self.clock = clock or time.monotonic  # the wall clock real time follows (tests inject)
        self.link_path = link_path
        self.realtime = realtime
        self.faults = faults
        self.disconnects = sorted((int(a * 1e6), int(b * 1e6)) for a, b in disconnects)
        self.endpoint = None
        self._out = b""
        self._present_since = None
        self.reconnects = 0
        self.skipped = 0  # times the board fell BEHIND_S behind and skipped ahead
        self._held = HoldLimit(self.clock)  # as fast as possible: time held for the host
        self.stop = False

    @property
    def path(self):
        return self.link_path or self.endpoint.path

    def open(self):
        endpoint = PtyEndpoint()
        if self.link_path:
            try:
                pty_link.point(self.link_path, endpoint.path)  # only over an emulator's link
            except InputError:
                endpoint.close()
                raise
        self.endpoint = endpoint
        return self.path

    def _unplugged(self, t_us):
        for a, b in self.disconnects:
            if a <= t_us < b:
                return b
        return None

    def _next_unplug(self, t_us):
        for a, _ in self.disconnects:
            if a > t_us:
                return a
        return None

    def serve(self, duration_s=None, tick_s=None, on_tick=None):
        """Run until ``stop`` is set or ``duration_s`` of simulated time has passed.

        ``tick_s``: simulated time between exchanges with the host (default ``TICK_S``
        in real time, ``FAST_TICK_S`` as fast as possible; ``realtime`` may change while
        serving).
        """
        if self.endpoint is None:
            self.open()
        board = self.board
        start = self.clock()
        end_us = None if duration_s is None else int(duration_s * 1e6)
        self._held.bounded = end_us is not None
        while not self.stop and (end_us is None or board.t_us < end_us):
            replug = self._unplugged(board.t_us)
            if replug is not None:
                if not self.realtime:
                    self._let_host_read()
                self._disconnect(replug)
                continue
            if self.realtime:
                ahead = board.t_us / 1e6 - (self.clock() - start)
                if ahead > 0:  # never run ahead of the wall clock
                    self._exchange(min(ahead, OPEN_SETTLE_S / 2))
                    continue
                if ahead < -BEHIND_S:  # behind: skip the polls there was no time for
                    self._skip(board.t_us - int(ahead * 1e6), end_us)
            elif self._held(not self.endpoint.host_present or bool(self._out)):
                self._wait_for_host()  # nobody there, or the last tick not taken: time holds
                continue
            target = board.t_us + int((tick_s or (TICK_S if self.realtime else FAST_TICK_S)) * 1e6)
            if end_us is not None:
                target = min(target, end_us)
            unplug = self._next_unplug(board.t_us)
            if unplug is not None:
                target = min(target, unplug)
            board.run_until(target)
            self._pump()
            if on_tick is not None:
                on_tick(board)
            self._exchange(0.0)
        self._pump()
        if not self.realtime:
            self._let_host_read()  # the end of the run reaches the host too

    def _wait_for_host(self):
        if not self.endpoint.host_present:
            self._pump()  # (what the board said before is discarded by _exchange)
            time.sleep(HOST_WAIT_S)  # (poll() returns at once while nobody has it open)
            self._exchange(0.0)
        else:
            self._exchange(FULL_WAIT_S)
            self._pump()

    def _skip(self, t_us, end_us):
        """Move the board's clock to ``t_us`` without polling (before an unplug or the end)."""
        for limit in (end_us, self._next_unplug(self.board.t_us)):
            if limit is not None:
                t_us = min(t_us, limit)
        self.board.skip_to(t_us)
        self.skipped += 1

    def _let_host_read(self):
        """As fast as possible: wait while the host (if any) reads what is queued or in flight,
        and gives up on one that takes nothing for ``HOLD_LIMIT_S``."""
        empty_since, stalled = None, Stalled(self.clock)
        while self.endpoint.host_present and not self.stop:
            self._exchange(FULL_WAIT_S)
            self._pump()
            state = (len(self._out), self.endpoint.unread())
            if stalled(state):
                return
            if any(state):
                empty_since = None
            elif empty_since is None:
                empty_since = time.monotonic()
            elif time.monotonic() - empty_since >= DRAINED_S:
                # (the input queue can read empty while the pty's buffer still holds more,
                # until the kernel moves it along: far less than DRAINED_S)
                return

    def _pump(self):
        board, ep = self.board, self.endpoint
        data = board.read_host()
        if data and self.faults is not None:
            data = self.faults.apply(data)
        self._out += data
        if self._out and ep.host_present:
            n = ep.write(self._out)
            self._out = self._out[n:]
        # Bytes the pty did not take stay queued; beyond the pty's buffer the board's own
        # TxRing decides what to drop, as with a host that stops reading.
        board.set_host_reading(ep.host_present and len(self._out) < 4096)

    def _exchange(self, wait_s):
        ep = self.endpoint
        readable, present = ep.wait(wait_s if wait_s > 0 else 0)
        now = time.monotonic()
        if present and self._present_since is None:
            self._present_since = now
        if not present:
            self._present_since = None
        announced = present and now - self._present_since >= OPEN_SETTLE_S
        if not announced:
            self._out = b""  # nobody is listening yet: the first thing a host sees is HELLO
        if announced and not ep.host_present:
            self.board.host_opened()
        ep.host_present = announced
        if readable:
            data = ep.read()
            if data:
                self.board.write_host(data)

    def _disconnect(self, until_us):
        """The cable is out until ``until_us``: the pty goes away, then a new one appears."""
        self.endpoint.close()
        if self.link_path:
            pty_link.remove(self.link_path)
        self.board.set_host_reading(False)
        start = time.monotonic()
        t0 = self.board.t_us
        while self.board.t_us < until_us and not self.stop:
            self.board.run_until(min(until_us, self.board.t_us + 2000))
            self.board.read_host()  # nothing leaves the board while unplugged
            if self.realtime:
                lag = (self.board.t_us - t0) / 1e6 - (time.monotonic() - start)
                if lag > 0:
                    time.sleep(lag)
        self._out = b""
        self._present_since = None
        self.open()
        self.reconnects += 1

    def close(self):
        if self.endpoint is not None:
            self.endpoint.close()
        if self.link_path:
            pty_link.remove(self.link_path)
