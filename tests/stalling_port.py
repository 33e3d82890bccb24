"""An emulated board behind a port whose host stalls (Ctrl-Z then ``fg``, a paused VM).

``StallingPort`` is a pyserial-like port for ``tactile.recording.session.Session`` on a
simulated host clock ``now`` that runs the board one to one.  The board's link (64 KB, as a
USB or pty buffer) holds what the host has not read; once it is full the board's own TX ring
fills and the board drops frames, counting them in STATUS ``tx_dropped``, as a real board
does for a host that is not reading.

``stall_s``: the host stands still that long inside its next read that waits for a first
byte (pyserial's ``read(1)`` after ``in_waiting`` said 0); the read then returns that one
byte, and everything the board sent meanwhile waits on the port.  ``clock_offset`` is added
to the host's clock only (a step back of the host's clock does not stop the board).
``hang()``: the firmware stops (no frame, no answer) from now on.  ``delivered``: every byte
the host was handed.
"""

from tactile_sim.emulator.device import EmulatedBoard

STEP_S = 0.0005  # host time per step of the board's simulation while a read waits


class StallingPort:
    def __init__(self, scene, host0=1000.0):
        self.board = EmulatedBoard(scene)
        self.host0 = self.now = host0
        self.timeout = 0.05
        self.stall_s = 0.0
        self.stalled = False
        self.clock_offset = 0.0
        self.hung = False
        self.delivered = bytearray()
        self.board.host_opened()

    # -- the host's clock ----------------------------------------------------------------
    def clock(self):
        return self.now + self.clock_offset

    def sleep(self, s):
        self.now += s

    # -- the board -------------------------------------------------------------------------
    def _run(self):
        if not self.hung:
            self.board.run_until(int((self.now - self.host0) * 1e6))

    def hang(self):
        self._run()
        self.hung = True

    @property
    def unread(self):
        return len(self.board.link.tx)

    def _take(self, n):
        link = self.board.link
        out = bytes(link.tx[:n])
        link.tx = link.tx[n:]
        self.delivered += out
        return out

    # -- the port --------------------------------------------------------------------------
    @property
    def in_waiting(self):
        self._run()
        return self.unread

    def read(self, size=1):
        self._run()
        if self.stall_s and not self.unread:  # blocked for its first byte, then stopped
            self.now += self.stall_s
            self.stall_s, self.stalled = 0.0, True
            self._run()
            return self._take(1)
        deadline = self.now + self.timeout
        while not self.unread and self.now < deadline:
            self.now = min(deadline, self.now + STEP_S)
            self._run()
        return self._take(size)

    def write(self, data):
        if not self.hung:
            self.board.write_host(bytes(data))
        return len(data)

    def close(self):
        pass
