"""Fakes for ``tactile flash``'s unit tests: a clock that moves only when told, and a serial
port that answers what a board of one kind answers, on that clock.

``BoardPort(kind)`` is pyserial-like (``read``, ``write``, ``in_waiting``, ``timeout``,
``close``).  A read moves the clock by ``READ_S``, one that finds nothing by the port's
timeout as well, as a real read waits it out; each read of a streaming board brings one
more frame.  Kinds:

- ``repl``: MicroPython at its REPL: the raw REPL's banner after CR, Ctrl-A.
- ``firmware``: the tactile firmware with ``BREAK_IN``: frames until CR, Ctrl-C, CR open
  a frame, then a traceback, the REPL's banner and, after Ctrl-A, the raw REPL's.
- ``no_repl``: the tactile firmware with no REPL behind it (the emulator's python core):
  HELLO, then frames forever; INFO to GET_INFO.  ``no_repl_quiet``: the same without HELLO.
- ``late``: a board that misses everything written in its first ``late_s``, then ``repl``.
- ``silent``: says nothing.  ``noise``: answers every write with the same text.
- ``dies``: its writes fail as a board unplugged.
"""

import serial
from lying_device import GOOD_INFO, frame

from tactile.stream_decoder import StreamDecoder
from tactile_protocol import constants as C

BANNER = b"raw REPL; CTRL-B to exit\r\n>"
TRACEBACK = (
    b'Traceback (most recent call last):\r\n  File "main.py", line 3, in <module>\r\n'
    b"BreakIn: \r\nMicroPython v1.29.0 on 2026-11-26; Raspberry Pi Pico with RP2040\r\n"
    b'Type "help()" for more information.\r\n>>> '
)
SAMPLE = (0, 0, 1, 2, 3, 4, 5, 6)
READ_S = 0.001  # what a read that finds bytes costs


class FakeClock:
    def __init__(self):
        self.t = 1000.0

    def __call__(self):
        return self.t

    def sleep(self, s):
        self.t += s


class BoardPort:
    """See the module docstring."""

    def __init__(self, kind, clock=None, late_s=3.0, timeout=0.05):
        self.kind = kind
        self.clock = clock or FakeClock()
        self.timeout = timeout
        self.late_until = self.clock() + late_s
        self.out = bytearray()
        self.written = bytearray()
        self.writes = []  # (clock, bytes)
        self.seq = 0
        self.running = kind in ("firmware", "no_repl", "no_repl_quiet")
        self.closed = False
        self.commands = StreamDecoder(check_limits=False)
        if kind in ("firmware", "no_repl"):
            self._frame(C.MSG_HELLO, GOOD_INFO)

    def _frame(self, mtype, values):
        self.out += frame(mtype, values, seq=self.seq, ts=1000 * self.seq)
        self.seq += 1

    # --- pyserial ------------------------------------------------------------------------
    @property
    def in_waiting(self):
        return len(self.out)

    def read(self, size=1):
        self.clock.sleep(READ_S)
        if not self.out and self.running:
            self._frame(C.MSG_SAMPLE, SAMPLE)
        if not self.out:
            self.clock.sleep(self.timeout)
            return b""
        data = bytes(self.out[:size])
        del self.out[:size]
        return data

    def write(self, data):
        if self.kind == "dies":
            raise serial.SerialException("write failed: [Errno 5] Input/output error")
        self.writes.append((self.clock(), bytes(data)))
        if self.kind == "late" and self.clock() < self.late_until:
            return len(data)
        self.written += data
        self._answer(bytes(data))
        return len(data)

    def close(self):
        self.closed = True

    # --- the board -------------------------------------------------------------------------
    def _answer(self, data):
        w = self.written
        if self.kind == "noise":
            self.out += b"ERR?\r\n\x1b[31m"
        elif self.kind == "firmware" and self.running and b"\x00\r\x03\r" in w:
            self.running = False
            self.out += TRACEBACK
            del w[: w.index(b"\x00\r\x03\r") + 4]  # Ctrl-A, if there, is the REPL's
        elif self.kind in ("no_repl", "no_repl_quiet"):
            for m in self.commands.feed(data):
                if m.type_code == C.CMD_GET_INFO:
                    self._frame(C.MSG_INFO, GOOD_INFO)
                    self._frame(C.MSG_ACK, (m.type_code, m.seq))
        if self.kind in ("repl", "late", "firmware") and not self.running and b"\x01" in w:
            self.out += BANNER  # Ctrl-A at the REPL
            del w[: w.index(b"\x01") + 1]
