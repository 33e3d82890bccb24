"""Tests that need a toolchain or a runtime (a C compiler, arm-none-eabi-gcc with newlib,
QEMU, node and its packages): skipped with one line naming what to install, and failed
instead under CI (``CI=true``), where every tool must be there."""

import functools
import os
import shutil
import subprocess
import tempfile

import pytest

NEWLIB = (
    "arm-none-eabi-gcc finds no C library headers (string.h): "
    "apt-get install libnewlib-arm-none-eabi"
)


def missing(why):
    """Skip with ``why`` (one line), or fail under CI."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI must have it: {why}", pytrace=False)
    pytest.skip(why)


def arm_tool(name):
    """The path of arm-none-eabi-``name``, or ``missing``."""
    path = shutil.which(f"arm-none-eabi-{name}")
    if path is None:
        missing(f"arm-none-eabi-{name}: apt-get install gcc-arm-none-eabi")
    return path


def arm_gcc():
    """arm-none-eabi-gcc with newlib's headers (the core includes string.h), or ``missing``."""
    gcc = arm_tool("gcc")
    if not _has_newlib(gcc):
        missing(NEWLIB)
    return gcc


@functools.cache
def _has_newlib(gcc):
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "probe.c")
        with open(src, "w") as f:
            f.write("#include <string.h>\nint probe(const char *s) { return (int)strlen(s); }\n")
        run = subprocess.run(
            [gcc, "-mcpu=cortex-m0plus", "-mthumb", "-c", src, "-o", os.path.join(tmp, "p.o")],
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
    return run.returncode == 0
