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

``FakeSession`` is a raw REPL session on a board whose filesystem is a directory.
"""

import builtins
import contextlib
import io
import os
import pathlib
import types

import serial
from lying_device import GOOD_INFO, frame

from tactile.board.raw_repl import Session
from tactile.board.stream_decoder import StreamDecoder
from tactile.errors import BoardError
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


class FakeSession:
    """``tactile.board.raw_repl.Session`` on a board whose filesystem is the directory ``root``:
    the code flash sends runs here under CPython, its ``os``, ``open`` and ``sys`` the
    board's (``sys.implementation._mpy`` is ``sys_mpy``).  ``fail_at``: the exec (counted
    from 0) that fails as a board that stopped answering.  ``snapshots``: the files after
    each exec."""

    write_file = Session.write_file  # the real one, through ``exec`` below

    def __init__(self, root, kind="repl", sys_mpy=4870, fail_at=None):
        self.name = "/dev/ttyACM0"
        self.root = pathlib.Path(root)
        self.serial = BoardPort(kind)
        self.sys_mpy, self.fail_at = sys_mpy, fail_at
        self.execs, self.snapshots = [], []
        self.entered = self.was_reset = self.closed = False
        on = self._path
        self.os = types.SimpleNamespace(
            remove=lambda p: os.remove(on(p)),
            listdir=lambda p: os.listdir(on(p)),
            mkdir=lambda p: os.mkdir(on(p)),
            rename=lambda a, b: os.rename(on(a), on(b)),
        )
        self.sys = types.SimpleNamespace(implementation=types.SimpleNamespace(_mpy=sys_mpy))

    def _path(self, p):
        return str(self.root / p.lstrip("/"))

    def _import(self, name, *args, **kw):
        return {"os": self.os, "sys": self.sys}.get(name) or builtins.__import__(name, *args, **kw)

    def _open(self, path, mode="r"):
        return open(self._path(path), mode)

    def enter(self, seconds):
        """A soft reset: the REPL's globals emptied (they last from one exec to the next)."""
        self.entered = True
        board = {**vars(builtins), "__import__": self._import, "open": self._open}
        self.scope = {"__builtins__": board}

    def exec(self, code, seconds, doing):
        if self.fail_at is not None and len(self.execs) == self.fail_at:
            raise BoardError(f"{self.name}: {doing}: no answer within {seconds:g} s")
        self.execs.append((doing, code))
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(code, self.scope)  # noqa: S102 - the board's part of a flash
        self.snapshots.append(self.files())
        return out.getvalue().encode()

    def reset(self, seconds):
        self.was_reset = True

    def close(self):
        self.closed = True

    def files(self):
        """{board path: bytes} of every file on the board."""
        return {
            "/" + str(p.relative_to(self.root)): p.read_bytes()
            for p in sorted(self.root.rglob("*"))
            if p.is_file()
        }

    def put(self, files):
        """Put ``files`` ({board path: bytes}) on the board, as an earlier flash left them."""
        for path, data in files.items():
            target = self.root / path.lstrip("/")
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
