"""Where a sampling poll's ARMv6-M instructions go, per function (issue 16, speed).

Run: ``.venv/bin/python bench/fw_c_profile.py`` (about a minute; a temporary trace of
about 150 MB).  The C core's micro:bit image runs its bench mode (``firmware/c/qemu/bench.c``,
the stage loops once, then 400 whole polls of the press scene's sensor at 1 kHz) in
``qemu-system-arm -M microbit`` with one instruction per translation block and
``-d exec``, so QEMU logs every instruction it executes.  Each logged address is charged to
the function that holds it (``arm-none-eabi-nm``); a poll runs from the entry of
``tc_board_poll`` until the bench's own code runs again, and only polls that calibrate
(take a sample) are counted.  ``bench/fw_c_qemu.py`` gives the totals from the timer; this
gives the split, with the HAL's share: the device channel that stands in for the I2C
peripheral (``hal_i2c_*``, ``dev_*``: semihosting requests) and the UART.
"""

import bisect
import collections
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.qemu_core import QEMU, QemuUnavailable, bench, image

GROUPS = [  # (group, function-name prefixes), first match wins
    ("calibrate", ("tc_cal_apply",)),
    ("gate", ("tc_gate_", "cmp.")),
    ("encode: pack, CRC-16, COBS", ("tc_pack", "tc_crc16", "tc_cobs_", "tc_encode", "tc_msg_d")),
    ("sensor read: 6 x (DRDY + RDATA), driver", ("tc_sensor_poll",)),
    ("HAL: I2C over the device channel", ("hal_i2c_", "dev_")),
    ("HAL: UART bytes out and in", ("hal_write", "hal_read")),
    ("board loop, TX ring, clock", ("tc_board_", "tx_", "tc_ticks_", "now_ticks", "hal_ticks")),
    ("libgcc and libc", ("__", "mem")),
]
_PC = re.compile(r"\[\w+/(\w+)/")


def one_insn_per_tb():
    """QEMU's switch for one instruction per block (renamed in QEMU 8.1)."""
    out = subprocess.run([shutil.which(QEMU), "--version"], capture_output=True, text=True)
    major = int(re.search(r"version (\d+)", out.stdout).group(1))
    return ["-singlestep"] if major < 8 else ["-accel", "tcg,one-insn-per-tb=on"]


def symbols(elf):
    """Sorted (address, name) of the image's functions."""
    nm = shutil.which("arm-none-eabi-nm")
    out = subprocess.run([nm, "-n", str(elf)], capture_output=True, text=True, check=True)
    syms = []
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] in "tTW":
            syms.append((int(parts[0], 16) & ~1, parts[2]))
    return syms


def polls(trace, syms):
    """Per-function instruction counts summed over the sampling polls, and their number."""
    addrs = [a for a, _ in syms]
    entry = dict((n, a) for a, n in syms)["tc_board_poll"]
    names, counts, seg, n_sampled = {}, collections.Counter(), None, 0

    def close(seg):
        if seg and seg["tc_cal_apply"]:
            counts.update(seg)
            return 1
        return 0

    with open(trace, errors="replace") as f:
        for line in f:
            m = _PC.search(line)
            if not m:
                continue
            pc = int(m.group(1), 16)
            name = names.get(pc)
            if name is None:
                name = names[pc] = syms[bisect.bisect_right(addrs, pc) - 1][1]
            if pc == entry:
                n_sampled += close(seg)
                seg = collections.Counter()
            elif name == "tc_qemu_bench" and seg is not None:
                n_sampled += close(seg)
                seg = None
            if seg is not None:
                seg[name] += 1
    return counts, n_sampled + close(seg)


def group_of(name):
    return next((g for g, prefixes in GROUPS if name.startswith(prefixes)), "other")


def main():
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="tactile-profile-"))
    trace = workdir / "exec.log"
    try:
        emu = EmulatedBoard(load_scene("press"), core="qemu", boot_id=1)
        bench(emu, profile=[*one_insn_per_tb(), "-d", "exec,nochain", "-D", str(trace)])
        counts, n = polls(trace, symbols(image()))
    except QemuUnavailable as exc:
        sys.exit(f"fw_c_profile: {exc}")
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    if not n:
        sys.exit("fw_c_profile: no sampling poll in the trace")
    total = sum(counts.values()) / n
    by_group = collections.Counter()
    for name, c in counts.items():
        by_group[group_of(name)] += c / n
    print(f"{n} sampling polls (press scene, 1 sensor, 1 kHz): {total:,.0f} instructions each\n")
    print("| part of a sampling poll | instructions | share |")
    print("|---|---:|---:|")
    for g, c in by_group.most_common():
        print(f"| {g} | {c:,.0f} | {c / total:.0%} |")
    print("\n| function | instructions per sampling poll |")
    print("|---|---:|")
    for name, c in counts.most_common():
        if c / n >= 5:
            print(f"| `{name}` | {c / n:,.0f} |")


if __name__ == "__main__":
    main()
