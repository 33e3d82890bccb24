"""Code size and RAM of the C firmware core for a Cortex-M0+ (the RP2040's core).

Compiles every ``firmware/c/tc_*.c`` with Debian's ``arm-none-eabi-gcc``
(``apt-get install gcc-arm-none-eabi``) at ``-mcpu=cortex-m0plus -mthumb -Os``, one
section per function, and prints, per file, flash (text + rodata) and RAM (data +
bss), plus ``sizeof(tc_board_t)``, the board's whole state for four sensors; the TX
ring (4096 bytes by default) is a separate buffer the caller sizes.

    .venv/bin/python bench/fw_c_size.py
"""

import pathlib
import shutil
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
SRC = ROOT / "firmware" / "c"
FLAGS = [
    "-std=c99",
    "-mcpu=cortex-m0plus",
    "-mthumb",
    "-Os",
    "-ffunction-sections",
    "-fdata-sections",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-I",
    str(SRC),
]
PROBE = '#include "tactile_core.h"\ntc_board_t tc_probe_board;\n'


def sizes(obj, size_tool):
    out = subprocess.run([size_tool, "-A", str(obj)], capture_output=True, text=True, check=True)
    flash = ram = 0
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) < 2 or not parts[1].isdigit():
            continue
        name, n = parts[0], int(parts[1])
        if name.startswith((".text", ".rodata")):
            flash += n
        elif name.startswith(".data"):
            flash += n
            ram += n
        elif name.startswith(".bss"):
            ram += n
    return flash, ram


def main():
    cc, size_tool = shutil.which("arm-none-eabi-gcc"), shutil.which("arm-none-eabi-size")
    if not cc or not size_tool:
        print("arm-none-eabi-gcc not installed (apt-get install gcc-arm-none-eabi)")
        return 1
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout
    print(f"`{version.splitlines()[0]}`, `{' '.join(FLAGS[1:4])}`\n")
    print("| file | flash (bytes) | RAM (bytes) |\n|---|---:|---:|")
    total = [0, 0]
    with tempfile.TemporaryDirectory() as tmp:
        for src in sorted(SRC.glob("tc_*.c")):
            obj = pathlib.Path(tmp) / (src.stem + ".o")
            subprocess.run([cc, *FLAGS, "-c", str(src), "-o", str(obj)], check=True)
            flash, ram = sizes(obj, size_tool)
            total[0] += flash
            total[1] += ram
            print(f"| {src.name} | {flash} | {ram} |")
        print(f"| **all** | **{total[0]}** | **{total[1]}** |")
        probe = pathlib.Path(tmp) / "probe.c"
        probe.write_text(PROBE)
        subprocess.run(
            [cc, *FLAGS, "-c", str(probe), "-o", str(probe.with_suffix(".o"))], check=True
        )
        board = sizes(probe.with_suffix(".o"), size_tool)[1]
    print(
        f"\n`sizeof(tc_board_t)` = {board} bytes (four sensors); plus the TX ring the "
        "caller provides (4096 bytes by default, at least 252) and the stack."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
