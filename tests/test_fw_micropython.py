"""The firmware on a real MicroPython interpreter (the WebAssembly port, under node).

The package comes from the npm registry on first use and is cached in
``$XDG_CACHE_HOME/tactile`` (``~/.cache/tactile``).  Without node/npm or the
registry the tests are skipped with the reason.
"""

import os
import pathlib
import shutil
import subprocess
import sys

import pytest
from toolchain import missing

from tactile.board import flashing

MP_PACKAGE = "@micropython/micropython-webassembly-pyscript"
MP_VERSION = "1.27.0"
HERE = pathlib.Path(__file__).parent
SIM = pathlib.Path(__file__).resolve().parents[1] / "sim" / "tactile_sim"


@pytest.fixture(scope="module")
def micropython_mjs():
    node, npm = shutil.which("node"), shutil.which("npm")
    if not node or not npm:
        missing("node and npm, for MicroPython's WebAssembly port: apt-get install nodejs npm")
    cache = pathlib.Path(os.environ.get("XDG_CACHE_HOME", pathlib.Path.home() / ".cache"))
    prefix = cache / "tactile" / f"micropython-wasm-{MP_VERSION}"
    mjs = prefix / "node_modules" / MP_PACKAGE / "micropython.mjs"
    if not mjs.exists():
        prefix.mkdir(parents=True, exist_ok=True)
        r = subprocess.run(
            [
                npm,
                "install",
                "--prefix",
                str(prefix),
                "--no-audit",
                "--no-fund",
                f"{MP_PACKAGE}@{MP_VERSION}",
            ],
            capture_output=True,
            text=True,
            timeout=300,
        )
        if r.returncode != 0 or not mjs.exists():
            missing(f"npm could not install {MP_PACKAGE}: {r.stderr.strip()[-200:]}")
    return mjs


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    """The board's /lib (exactly what `tactile flash` copies) plus the simulated ADC and bus,
    and the power cuts of tests/power_cut.py."""
    root = tmp_path_factory.mktemp("board")
    for src, dest in flashing.board_files():
        target = root / dest.removeprefix("lib/")
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, target)
    (root / "tactile_sim").mkdir()
    for name in ("__init__.py", "adc_model.py", "i2c_bus.py"):
        shutil.copyfile(SIM / name, root / "tactile_sim" / name)
    shutil.copyfile(HERE / "power_cut.py", root / "power_cut.py")
    return root


def run_micropython(mjs, stage, script):
    r = subprocess.run(
        ["node", str(HERE / "fw_mpy_run.mjs"), str(mjs), str(stage), str(script)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_scenario_output_is_byte_identical_on_micropython_and_cpython(micropython_mjs, stage):
    script = HERE / "fw_mpy_scenario.py"
    mp = run_micropython(micropython_mjs, stage, script)
    cp = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, check=True
    ).stdout
    assert mp == cp
    last = mp.splitlines()[-1].split()
    assert last[:2] == ["samples", "70"] and last[3] == "3"  # streamed, faulted, recovered
    assert len(mp.splitlines()) == 5 and all(len(line) > 40 for line in mp.splitlines()[:4])


def test_heap_use_per_call_on_micropython(micropython_mjs, stage):
    """gc.mem_alloc with the collector off: the driver and the calibration allocate nothing.

    The calibration is integer fixed point kept below 2^30 (small ints); the gate's band
    path and the encoder may allocate a little; bounds against regressions, firmware.md.
    """
    out = run_micropython(micropython_mjs, stage, HERE / "fw_mpy_alloc.py")
    used = {k: int(v) for k, v in (line.split() for line in out.splitlines())}
    assert used["read"] == 0
    assert used["encode"] <= 32
    assert used["gate"] <= 128
    assert used["calibrate"] == 0
    assert used["poll"] <= used["read"] + used["calibrate"] + used["gate"] + used["encode"] + 256


def test_a_power_cut_at_any_flash_call_on_micropython_boots_the_old_or_the_new_copy(
    micropython_mjs, stage
):
    """tests/power_cut.py on MicroPython's own os and open (the WebAssembly port's
    filesystem): a cut at every call of writing settings.bin and cal0.bin, then a boot, with
    a rename that replaces and one that refuses an existing file."""
    mp = run_micropython(micropython_mjs, stage, HERE / "fw_mpy_power_cut.py")
    lines = [line.split() for line in mp.splitlines()]
    boots = [line for line in lines if line[1].isdigit()]
    assert {line[2] for line in boots} >= {"open", "write", "close", "rename", "remove"}
    assert [line for line in boots if not {line[3], line[4]} <= {"old", "new"}] == []
    for kind in ("replaces", "refuses"):  # each sweep ends with the writes done, uncut
        assert [line for line in boots if line[0] == kind][-1][2:] == ["None", "new", "new"]
    assert lines[-1][:3] == ["refuses", "second", "cuts"] and int(lines[-1][3]) > 100
    assert lines[-1][4:] == ["bad", "0"]
