"""MicroPython: time and heap per calibration, float product (before) against fixed point.

Runs ``bench/mpy/cal_speed_board.py`` on MicroPython 1.27's WebAssembly port under node
(installed by ``tests/test_fw_micropython.py`` into ~/.cache/tactile; run that test once
first), with the float calibration of ``git show 4b6ab8e:firmware/tactile_fw/calibration.py``
staged as ``cal_old.py``. Best of 8 x 3000 calls, alternating; wasm computes floats in native
doubles, so on an rp2 (soft float32, heap floats) the float product is relatively slower.

    .venv/bin/python bench/fw_mpy_cal_speed.py
"""

import pathlib
import shutil
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def main():
    import test_fw_micropython as t

    from tactile.board import flashing

    mjs = (
        pathlib.Path.home()
        / ".cache/tactile"
        / f"micropython-wasm-{t.MP_VERSION}/node_modules"
        / t.MP_PACKAGE
        / "micropython.mjs"
    )
    if not mjs.exists():
        print("MicroPython wasm not installed: run pytest tests/test_fw_micropython.py once")
        return 1
    old = subprocess.run(
        ["git", "show", "4b6ab8e:firmware/tactile_fw/calibration.py"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        for src, dest in flashing.board_files():
            target = root / dest.removeprefix("lib/")
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, target)
        (root / "cal_old.py").write_text(old)
        print(t.run_micropython(mjs, root, ROOT / "bench" / "mpy" / "cal_speed_board.py"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
