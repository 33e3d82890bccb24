"""The README's recording blocks run exactly as written (issue 14): each block in a fresh
directory whose ``.venv`` is this interpreter's environment.  A line marked ``terminal 1``
(``tactile emulate``) runs in the background; the pty it prints replaces ``/dev/pts/N`` in
the lines after it.  Every other line must exit 0 without a traceback or a NaN, every
``record`` must end on its own, and every ``ep2 analyze`` must name the scene's shape."""

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

SHAPE = {"ch5_convex": "cylinder", "ep2_sweep_sphere": "sphere"}


def _blocks(heading, until):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index(heading) : text.index(until)]
    blocks = re.findall(r"```sh\n(.*?)```", section, re.S)
    return [b.strip().splitlines() for b in blocks if "tactile emulate" in b]


BLOCKS = _blocks("### `tactile record --port P", "**Tests (no hardware):**")


def test_the_record_section_shows_both_emulated_paths():
    scenes = [re.search(r"emulate (\S+)", block[0]).group(1) for block in BLOCKS]
    assert scenes == ["ch5_convex", "ep2_sweep_sphere"]
    assert any("sim://ep2_sweep_sphere" in line for line in BLOCKS[1])


@pytest.mark.slow
@pytest.mark.parametrize("block", BLOCKS, ids=lambda b: re.search(r"emulate (\S+)", b[0])[1])
def test_the_block_runs_as_written(tmp_path, block):
    assert "# terminal 1" in block[0] and all(ln.startswith(".venv/bin/tactile ") for ln in block)
    scene = re.search(r"emulate (\S+)", block[0]).group(1)
    os.symlink(Path(sys.executable).absolute().parents[1], tmp_path / ".venv")
    roots = [str(ROOT / d) for d in ("protocol", "firmware", "host", "sim", "studies")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(roots))  # this tree, from any cwd
    emulator = subprocess.Popen(block[0], shell=True, cwd=tmp_path, env=env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                start_new_session=True)  # fmt: skip
    try:
        pty = emulator.stdout.readline().strip()
        assert pty.startswith("/dev/"), emulator.stderr.read()
        for line in block[1:]:
            r = subprocess.run(line.replace("/dev/pts/N", pty), shell=True, cwd=tmp_path,
                               env=env, capture_output=True, text=True, timeout=300)  # fmt: skip
            assert r.returncode == 0 and "Traceback" not in r.stderr, (line, r.stderr)
            assert not re.search(r"\b(nan|inf|infinity)\b", r.stdout, re.I), r.stdout
            assert "warning:" not in r.stderr, (line, r.stderr)
            if " record " in line:
                assert re.search(r"\((pose log end|contacts)\)", r.stdout), r.stdout
                assert "lost 0 frames" in r.stdout
            if " analyze " in line:
                assert f" {SHAPE[scene]} " in r.stdout, r.stdout
    finally:  # the shell and the emulator it started: no emulator outlives its test
        os.killpg(emulator.pid, signal.SIGTERM)
        emulator.wait(10)
