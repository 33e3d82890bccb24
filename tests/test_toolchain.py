"""A missing toolchain or runtime is one skip line naming what to install, and a failure
under CI (``toolchain.missing``); arm-none-eabi-gcc without newlib is caught before a
compile fails on string.h."""

import shutil
import subprocess

import pytest
import toolchain


def test_a_missing_tool_is_a_skip_naming_the_package(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(pytest.skip.Exception, match="apt-get install gcc-arm-none-eabi"):
        toolchain.arm_gcc()


def test_under_ci_a_missing_tool_fails(monkeypatch):
    monkeypatch.setenv("CI", "true")
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(pytest.fail.Exception, match="CI must have it: .*gcc-arm-none-eabi"):
        toolchain.arm_gcc()


def test_a_cross_compiler_without_newlib_names_newlib(monkeypatch):
    """The probe compiles '#include <string.h>': a compiler that cannot is newlib missing."""
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setattr(shutil, "which", lambda name: "/usr/bin/" + name)
    toolchain._has_newlib.cache_clear()
    failed = subprocess.CompletedProcess([], 1, "", "fatal error: string.h: No such file")
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: failed)
    with pytest.raises(pytest.skip.Exception, match="libnewlib-arm-none-eabi"):
        toolchain.arm_gcc()
    toolchain._has_newlib.cache_clear()
