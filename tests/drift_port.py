"""An emulated board behind a USB link with a drifting clock and jittery delivery.

``DriftingPort`` is a pyserial-like port for ``tactile.recording.session.Session``.  Its host
clock ``now`` is simulated; the board's runs ``drift_ppm`` fast against it (board s =
(host s - ``host0``) * (1 + drift)); every frame reaches the host
``jitter_s`` late at most after the instant its stamp names (uniform; in order, as USB
delivers).  ``host_of(board_us)`` is
the truth the recorder's fit is judged against.
"""

import collections
import struct

import numpy as np

from tactile_protocol.cobs_codec import decode
from tactile_sim.emulator.device import EmulatedBoard

STEP_S = 0.0005  # host time per step of the board's simulation


class DriftingPort:
    def __init__(self, scene, drift_ppm=50.0, jitter_s=0.005, host0=5000.0, seed=0):
        self.board = EmulatedBoard(scene)
        self.rate = 1.0 + drift_ppm * 1e-6  # board seconds per host second
        self.jitter_s = jitter_s
        self.host0 = host0
        self.now = host0
        self.timeout = 0.05
        self.rng = np.random.default_rng(seed)
        self.queue = collections.deque()  # (delivery host s, bytes)
        self.last_delivery = host0
        self.made = host0  # host time the board has been run to
        self.board.host_opened()

    # -- the truth ------------------------------------------------------------------
    def host_of(self, board_us):
        return self.host0 + np.asarray(board_us, dtype=float) * 1e-6 / self.rate

    # -- simulated time ---------------------------------------------------------------
    def clock(self):
        return self.now

    def sleep(self, s):
        self.now += s
        self._produce()

    def _produce(self):
        """Run the board until what it emits can no longer arrive before ``now``; queue each
        frame at its own arrival (host time of its stamp plus jitter, in order).  A command
        written at ``now`` reaches the board within ``STEP_S + jitter_s``."""
        until = self.now + self.jitter_s + STEP_S
        while self.made < until:
            self.made = min(until, self.made + STEP_S)
            self.board.run_until(int((self.made - self.host0) * self.rate * 1e6))
            for frame in self.board.read_host().split(b"\0")[:-1]:
                stamp = struct.unpack_from("<I", decode(frame), 4)[0]  # header: board us
                late = float(self.host_of(stamp)) + self.rng.uniform(0.0, self.jitter_s)
                self.last_delivery = max(self.last_delivery, late)  # USB keeps the order
                self.queue.append((self.last_delivery, frame + b"\0"))

    def _ready(self):
        self._produce()
        n = 0
        for at, data in self.queue:
            if at > self.now:
                break
            n += len(data)
        return n

    # -- the port -------------------------------------------------------------------
    @property
    def in_waiting(self):
        return self._ready()

    def read(self, size=1):
        """Block (in simulated time) until a frame has arrived or the timeout passed; the
        host wakes at the arrival itself, not on a grid."""
        deadline = self.now + self.timeout
        while not self._ready() and self.now < deadline:
            nxt = self.queue[0][0] if self.queue else deadline  # _ready ran the board ahead
            self.now = min(deadline, self.now + STEP_S, max(nxt, self.now + 1e-6))
        out = bytearray()
        while self.queue and self.queue[0][0] <= self.now and len(out) < size:
            at, data = self.queue.popleft()
            take = size - len(out)
            out += data[:take]
            if len(data) > take:
                self.queue.appendleft((at, data[take:]))
        return bytes(out)

    def write(self, data):
        self.board.write_host(bytes(data))
        return len(data)

    def close(self):
        pass
