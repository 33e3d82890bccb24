"""The C core cross-compiled for a Cortex-M0 image that QEMU runs (``-M microbit``).

``build(out_dir)`` compiles ``firmware/c/tc_*.c`` and the micro:bit port
(``firmware/c/qemu``: startup, UART/TIMER HAL, semihosting device channel, bench) with
Debian's ``arm-none-eabi-gcc -mcpu=cortex-m0plus -mthumb -Os`` into an ELF, reused while
the sources, flags and compiler are unchanged.  ``NoToolchain`` when the cross compiler is
missing.  ``python -m tactile_fw_tools.cross [OUT_DIR]`` (what ``make firmware-c``
runs) prints the image's path and size.  Host only: never copied to a board.
"""

import hashlib
import os
import pathlib
import shutil
import subprocess
import sys

SRC = pathlib.Path(__file__).resolve().parents[2] / "firmware" / "c"
PORT = SRC / "qemu"
CC = "arm-none-eabi-gcc"
CFLAGS = (
    "-mcpu=cortex-m0plus", "-mthumb", "-Os", "-std=gnu99", "-Wall", "-Wextra", "-Werror",
    "-ffunction-sections", "-fdata-sections",
)  # fmt: skip
LDFLAGS = ("-nostartfiles", "--specs=nano.specs", "-Wl,--gc-sections")
INSTALL = "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi"


class NoToolchain(RuntimeError):
    """No arm-none-eabi-gcc (or its newlib) on this machine."""


class ImageBuildError(RuntimeError):
    """The cross compiler refused the image."""


def sources():
    return sorted(SRC.glob("tc_*.c")) + sorted(PORT.glob("*.c"))


def build(out_dir, name="tactile_microbit-{digest}.elf"):
    """The ELF image in ``out_dir`` (``{digest}``: a hash of sources, flags and compiler)."""
    cc = shutil.which(CC)
    if cc is None:
        raise NoToolchain(f"no {CC} on PATH: {INSTALL}")
    digest = hashlib.sha256()
    for f in [*sources(), *sorted(SRC.glob("*.h")), *sorted(PORT.glob("*.[hl]*"))]:
        digest.update(f.read_bytes())
    digest.update(repr((cc, CFLAGS, LDFLAGS)).encode())
    out = pathlib.Path(out_dir) / name.format(digest=digest.hexdigest()[:16])
    if out.exists() and "{digest}" in name:  # (a fixed name is built every time)
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f"{out.name}.{os.getpid()}.tmp")
    cmd = [cc, *CFLAGS, "-I", str(SRC), "-I", str(PORT), *map(str, sources()),
           "-T", str(PORT / "microbit.ld"), *LDFLAGS, "-o", str(tmp)]  # fmt: skip
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        tmp.unlink(missing_ok=True)
        if "nano.specs" in r.stderr:
            raise NoToolchain(f"{CC} has no newlib (nano.specs): {INSTALL}")
        raise ImageBuildError(f"{' '.join(cmd)} failed:\n{r.stderr}")
    os.replace(tmp, out)  # other processes never see a half-written image
    return out


def size(elf):
    """(flash, RAM) bytes of ``elf``: text + data, data + bss (arm-none-eabi-size)."""
    tool = shutil.which("arm-none-eabi-size")
    out = subprocess.run([tool, str(elf)], capture_output=True, text=True, check=True).stdout
    text, data, bss = (int(v) for v in out.splitlines()[1].split()[:3])
    return text + data, data + bss


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    out_dir = pathlib.Path(argv[0] if argv else "build/firmware-c")
    try:
        elf = build(out_dir, name="tactile_microbit.elf")
    except (NoToolchain, ImageBuildError) as exc:
        print(f"firmware-c: {exc}", file=sys.stderr)
        return 4 if isinstance(exc, NoToolchain) else 1
    flash, ram = size(elf)
    print(f"{elf}: {flash} bytes of flash, {ram} bytes of RAM (Cortex-M0, micro:bit)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
