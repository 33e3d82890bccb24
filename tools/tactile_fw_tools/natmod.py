"""The C core as a MicroPython native module for the Raspberry Pi Pico (``tactile_native.mpy``).

``build(out_dir)`` compiles ``firmware/c/tc_*.c`` and the module's wrapper
(``firmware/c/natmod/tactile_native.c``) with MicroPython's own natmod build:
``py/dynruntime.mk`` with ``ARCH=armv6m`` and ``LINK_RUNTIME=1`` (libgcc's 64-bit and divide
helpers), linked by ``tools/mpy_ld.py`` into an ``.mpy`` that MicroPython 1.29's rp2 port
imports (mpy version 6.3).  MicroPython's sources come from ``micropython-natmod-src.tar.gz``
(``py/`` and ``tools/`` at the Pico image's commit, af47daf3b0) in ``$TACTILE_RP2_DIR`` or
``<repo>/../shared/rp2``.  The build runs in a scratch folder (mpy_ld keeps a cache in its
working folder) with ``PYTHONHASHSEED=0`` (mpy_ld orders libgcc's members through a set), so
the same sources and compiler give the same bytes.

``python -m tactile_fw_tools.natmod [OUT]`` (``make natmod``) writes the module shipped in
the package, ``firmware/tactile_fw/tactile_native.mpy``, which ``tactile flash`` copies to the
board's ``/lib``: users need no cross-compiler.  ``tests/test_natmod.py`` rebuilds it and
checks it is byte-identical.  Host only: never copied to a board.
"""

import importlib.util
import os
import pathlib
import shutil
import subprocess
import sys
import tarfile
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
SRC = ROOT / "firmware" / "c"
NATMOD = SRC / "natmod"
SHIPPED = ROOT / "firmware" / "tactile_fw" / "tactile_native.mpy"
TARBALL = "micropython-natmod-src.tar.gz"
CC = "arm-none-eabi-gcc"
INSTALL_CC = "apt-get install gcc-arm-none-eabi"


class NoToolchain(RuntimeError):
    """Something the build needs is missing; the message names it and how to get it."""


class NatmodBuildError(RuntimeError):
    """The compiler or MicroPython's linker refused the module."""


def rp2_dir():
    """The folder holding MicroPython's natmod sources (the tarball), or NoToolchain."""
    env = os.environ.get("TACTILE_RP2_DIR")
    folder = pathlib.Path(env) if env else ROOT.parent / "shared" / "rp2"
    if not (folder / TARBALL).is_file():
        where = f"TACTILE_RP2_DIR={env}" if env else f"{folder} (set TACTILE_RP2_DIR)"
        raise NoToolchain(f"no {TARBALL} in {where}: MicroPython's py/ and tools/mpy_ld.py")
    return folder


def check_tools():
    """The tools the build runs, or NoToolchain naming the first one missing."""
    if shutil.which(CC) is None:
        raise NoToolchain(f"no {CC} on PATH: {INSTALL_CC}")
    if shutil.which("make") is None:
        raise NoToolchain("no make on PATH: apt-get install make")
    for module, package in (("elftools", "pyelftools"), ("ar", "ar")):
        if importlib.util.find_spec(module) is None:
            raise NoToolchain(f"no Python package {package} (MicroPython's mpy_ld.py needs it): "
                              f"pip install {package}")  # fmt: skip
    return rp2_dir()


def sources():
    """Every file the module is built from (the core, its header, the wrapper, the Makefile)."""
    return [*sorted(SRC.glob("tc_*.c")), *sorted(SRC.glob("*.h")), *sorted(NATMOD.iterdir())]


def build(out_dir):
    """Build ``tactile_native.mpy`` into ``out_dir``; its path."""
    folder = check_tools()
    out = pathlib.Path(out_dir) / SHIPPED.name
    with tempfile.TemporaryDirectory(prefix="tactile-natmod-") as tmp:
        work = pathlib.Path(tmp)
        with tarfile.open(folder / TARBALL) as tar:
            tar.extractall(work / "micropython", filter="data")
        shutil.copyfile(NATMOD / "Makefile", work / "Makefile")
        env = dict(os.environ, PYTHONHASHSEED="0", LC_ALL="C")
        cmd = ["make", "-s", f"MPY_DIR={work / 'micropython'}", f"CORE_DIR={SRC}",
               f"PYTHON={sys.executable}"]  # fmt: skip
        r = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True)
        built = work / SHIPPED.name
        if r.returncode != 0 or not built.is_file():
            said = (r.stdout + r.stderr).strip().splitlines()
            raise NatmodBuildError(f"{' '.join(cmd)} failed:\n" + "\n".join(said[-20:]))
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp_out = out.with_name(f"{out.name}.{os.getpid()}.tmp")
        shutil.copyfile(built, tmp_out)
        os.replace(tmp_out, out)  # never half a module where a flash would copy it from
    return out


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    out_dir = pathlib.Path(argv[0]) if argv else SHIPPED.parent
    try:
        mpy = build(out_dir)
    except (NoToolchain, NatmodBuildError) as exc:
        print(f"natmod: {exc}", file=sys.stderr)
        return 4 if isinstance(exc, NoToolchain) else 1
    data = mpy.read_bytes()
    print(f"{mpy}: {len(data)} bytes, mpy version {data[1]}.{data[2] & 3} (armv6m, C core + "
          "MicroPython wrapper)")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
