"""A board's raw REPL through mpremote's ``SerialTransport``, every wait bounded.

mpremote waits in three ways that need not end: ``serial.read`` on a port it opens
without a timeout, ``read_until`` with a timeout between bytes but none overall (a board
that keeps talking keeps it reading), and the input flush of ``enter_raw_repl``, which
reads for as long as bytes come.  On a port that streams frames ``tactile flash`` waited
657 s.  Here the port gets a read timeout, and ``read_until`` and ``enter_raw_repl`` are
replaced by versions that stop at the session's deadline, which every step sets
(``Session.step``); the rest of mpremote (raw-paste, ``exec``, ``follow``) is used as is.
A step that fails or runs out of time is one ``BoardError`` line naming the step.

mpremote is the ``board`` extra, imported only when a session opens (``tactile.extras``).
"""

import binascii
import contextlib
import functools
import time

from tactile.board.serial_port import describe_lost, open_port
from tactile.errors import BoardError, PortError, PortLost, TactileError
from tactile.extras import need

READ_TIMEOUT_S = 2.0  # mpremote's own reads (a raw-paste window, "OK"): at most this long
POLL_S = 0.002  # read_until's look at the port while nothing is waiting
DRAIN_S = 1.0  # enter_raw_repl's input flush, at most
CHUNK = 1024  # file bytes an exec as a bytes literal
B64_CHUNK = 3072  # file bytes an exec in base64: 4 KB (the fastest of 0.5-4 KB on the emulator)
PURPOSE = "Flashing a board"


@functools.cache
def _bounded_transport():
    """mpremote's SerialTransport with the two waits replaced (the class is made on first
    use: mpremote is an optional extra)."""
    (mod,) = need("board", PURPOSE, "mpremote.transport_serial")

    class Bounded(mod.SerialTransport):
        deadline = None  # time.monotonic() at which every read gives up

        def _end(self, timeout_overall):
            now = time.monotonic()
            ends = [e for e in (self.deadline, timeout_overall and now + timeout_overall) if e]
            return min(ends) if ends else now + 10.0

        def read_until(
            self, min_num_bytes, ending, timeout=10, data_consumer=None, timeout_overall=None
        ):
            """mpremote's, one byte at a time (what follows ``ending`` is the next read's),
            ending at the deadline as well."""
            data = b""
            end = self._end(timeout_overall)
            last = time.monotonic()
            while not data.endswith(ending):
                now = time.monotonic()
                if now >= end or (timeout is not None and now - last >= timeout):
                    break
                if not self.serial.in_waiting:
                    time.sleep(POLL_S)
                    continue
                byte = self.serial.read(1)
                if not byte:
                    continue
                last = now
                if data_consumer is not None:
                    data_consumer(byte)
                    data = byte
                else:
                    data += byte
            return data

        def enter_raw_repl(self, soft_reset=True, timeout_overall=10):
            """mpremote's, with the input flush bounded and no print on failure."""

            def expect(ending, what):
                if not self.read_until(1, ending, timeout_overall=timeout_overall).endswith(ending):
                    raise mod.TransportError(what)

            banner = b"raw REPL; CTRL-B to exit\r\n"
            self.serial.write(b"\r\x03")  # ctrl-C: stop a program
            end = min(time.monotonic() + DRAIN_S, self._end(None))
            while self.serial.in_waiting and time.monotonic() < end:
                self.serial.read(self.serial.in_waiting)
            self.serial.write(b"\r\x01")  # ctrl-A: the raw REPL
            if soft_reset:
                expect(banner + b">", "could not enter raw repl")
                self.serial.write(b"\x04")  # ctrl-D: soft reset
                expect(b"soft reboot\r\n", "no soft reboot")
            expect(banner, "could not enter raw repl")
            self.in_raw_repl = True

    return Bounded, mod.TransportError


def need_mpremote():
    """mpremote, or ``MissingExtra`` saying how to install it (exit 2)."""
    _bounded_transport()


class Session:
    """An open raw REPL on ``port``: ``step`` bounds and names each thing done through it."""

    def __init__(self, port):
        self.name = port
        transport, self._transport_error = _bounded_transport()
        try:
            self.t = transport(port, baudrate=115200, wait=0, exclusive=True)
        except (self._transport_error, OSError):
            raise _why_not_open(port) from None
        self.t.serial.timeout = READ_TIMEOUT_S

    @property
    def serial(self):
        """The open pyserial port (``tactile.board.probe`` talks to it before the REPL)."""
        return self.t.serial

    @contextlib.contextmanager
    def step(self, seconds, doing):
        """Run the block within ``seconds``; a failure is one line naming ``doing``."""
        self.t.deadline = time.monotonic() + seconds
        try:
            yield
        except TactileError:
            raise
        except self._transport_error as exc:
            late = time.monotonic() >= self.t.deadline
            why = f"no answer within {seconds:g} s" if late else _last_line(exc)
            raise BoardError(f"{self.name}: {doing}: {why}") from None
        except OSError as exc:  # the port died: pyserial's SerialException is an OSError
            raise PortLost(describe_lost(self.name, exc, doing)) from None
        finally:
            self.t.deadline = None

    def enter(self, seconds):
        """The raw REPL, after a soft reset (a clean heap, and no main.py: raw mode)."""
        with self.step(seconds, "entering the raw REPL"):
            self.t.enter_raw_repl(soft_reset=True)

    def exec(self, code, seconds, doing):
        """Run ``code`` on the board; its output (bytes)."""
        with self.step(seconds, doing):
            return self.t.exec(code)

    def write_file(self, path, data, seconds, progress=None, b64=True):
        """Write ``data`` (bytes, any content) to ``path`` on the board, one exec a chunk
        (the first opens the file, the last closes it), each within ``seconds``; base64
        (``binascii.a2b_base64`` on the board, 1.33 bytes a byte) or, ``b64=False``, a bytes
        literal (up to 4 a byte).  ``progress(n)`` after each chunk's ``n`` bytes."""
        size = B64_CHUNK if b64 else CHUNK
        parts = [data[at : at + size] for at in range(0, len(data), size)] or [b""]
        head = ("from binascii import a2b_base64 as A\n" if b64 else "") + f"f=open({path!r},'wb')"
        for i, part in enumerate(parts):
            if b64:
                code = [f"f.write(A({binascii.b2a_base64(part, newline=False)!r}))"]
            else:
                code = [f"f.write({part!r})"]
            if i == 0:
                code.insert(0, head)
            if i == len(parts) - 1:
                code.append("f.close()")
            self.exec("\n".join(code), seconds, f"writing {path}")
            if progress is not None:
                progress(len(part))

    def reset(self, seconds):
        """``machine.reset()``, not waiting for an answer: the board is gone after it."""
        with self.step(seconds, "resetting the board"):
            self.t.exec_raw_no_follow("import machine\nmachine.reset()")

    def close(self):
        """Close the port; one that vanished (a board that reset) closes without complaint."""
        with contextlib.suppress(OSError, self._transport_error):
            self.t.close()


def _last_line(exc):
    text = str(exc).strip()
    return text.splitlines()[-1] if text else type(exc).__name__


def _why_not_open(port):
    """mpremote says only "failed to access": open the port plainly for the reason."""
    try:
        open_port(port).close()
    except PortError as exc:
        return exc
    return PortError(f"{port}: cannot open (mpremote: failed to access it)")
