"""Serve an emulated board on a pseudo-terminal, paced in real time or as fast as possible.

The slave side is a real tty: the host opens its path with pyserial exactly
as it opens ``/dev/ttyACM0``.  A stable symlink (``--link``) points at the
current slave, so a simulated disconnect (the pty vanishes) and reconnect
(a new pty) look like a cable pulled and plugged back.  The master sees
``POLLHUP`` while no host has the slave open: the board's writes then find
no reader and the firmware drops and counts frames, as on USB; when a host
opens the port the firmware is told (it answers with HELLO), after a short
settle time: pyserial flushes the input buffer at the end of ``open()``, so a
HELLO written the instant the port opens would be discarded.
"""

import errno
import os
import select
import time
import tty

OPEN_SETTLE_S = 0.05  # wait this long after the host opens before announcing


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
        """Wait for host input or a change of host presence; return (readable, present)."""
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

    def close(self):
        os.close(self.master)


class PtyServer:
    """Run ``board`` (an EmulatedBoard) behind a pty until ``stop`` or the duration."""

    def __init__(self, board, link_path=None, realtime=True, faults=None, disconnects=()):
        self.board = board
        self.link_path = link_path
        self.realtime = realtime
        self.faults = faults
        self.disconnects = sorted((int(a * 1e6), int(b * 1e6)) for a, b in disconnects)
        self.endpoint = None
        self._out = b""
        self._present_since = None
        self.reconnects = 0
        self.stop = False

    @property
    def path(self):
        return self.link_path or self.endpoint.path

    def open(self):
        self.endpoint = PtyEndpoint()
        if self.link_path:
            tmp = f"{self.link_path}.tmp{os.getpid()}"
            os.symlink(self.endpoint.path, tmp)
            os.replace(tmp, self.link_path)
        return self.path

    def _unplugged(self, t_us):
        for a, b in self.disconnects:
            if a <= t_us < b:
                return b
        return None

    def serve(self, duration_s=None, tick_s=0.002, on_tick=None):
        """Run until ``stop`` is set or ``duration_s`` of simulated time has passed."""
        if self.endpoint is None:
            self.open()
        board = self.board
        start = time.monotonic()
        end_us = None if duration_s is None else int(duration_s * 1e6)
        while not self.stop and (end_us is None or board.t_us < end_us):
            replug = self._unplugged(board.t_us)
            if replug is not None:
                self._disconnect(replug)
                continue
            ahead = board.t_us / 1e6 - (time.monotonic() - start)
            if self.realtime and ahead > 0:  # never run ahead of the wall clock
                self._exchange(min(ahead, OPEN_SETTLE_S / 2))
                continue
            target = board.t_us + int(tick_s * 1e6)
            if end_us is not None:
                target = min(target, end_us)
            board.run_until(target)
            self._pump()
            if on_tick is not None:
                on_tick(board)
            self._exchange(0.0)
        self._pump()

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
        if self.link_path and os.path.islink(self.link_path):
            os.unlink(self.link_path)
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
        if self.link_path and os.path.islink(self.link_path):
            os.unlink(self.link_path)
