"""docs/recordings.md's example runs as written: its shell block line by line, then its
Python block, in a fresh directory whose ``.venv`` is this interpreter's environment."""

import os
import re
import subprocess
import sys
from pathlib import Path

from conftest import ROOT


def _blocks(heading):
    text = (ROOT / "docs" / "recordings.md").read_text(encoding="utf-8")
    section = text[text.index(heading) :]
    shell = re.search(r"```sh\n(.*?)```", section, re.S).group(1).strip().splitlines()
    python = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    return shell, python


def test_the_recordings_example_runs_as_written(tmp_path):
    shell, python = _blocks("## The example, end to end")
    assert len(shell) == 2 and all(line.startswith(".venv/bin/tactile ") for line in shell)
    os.symlink(Path(sys.executable).absolute().parents[1], tmp_path / ".venv")
    for line in shell:
        r = subprocess.run(line, shell=True, cwd=tmp_path, capture_output=True, text=True)
        assert r.returncode == 0 and "Traceback" not in r.stderr, (line, r.stderr)
    r = subprocess.run([sys.executable, "-c", python], cwd=tmp_path, capture_output=True,
                       text=True)  # fmt: skip
    assert r.returncode == 0 and r.stderr == "", r.stderr
    out = r.stdout.splitlines()
    assert not re.search(r"\b(nan|inf|infinity)\b", r.stdout, re.I), r.stdout
    n = int(re.match(r"(\d+) readings from sensors \[0\]$", out[0]).group(1))
    assert n > 100
    assert re.match(r"peak \|F\| \d+\.\d\d N at board time \d+\.\d{3} s$", out[1])
    assert out[2].startswith(("  host UTC ", "  no host time: "))
    touching = re.match(r"(\d+) readings in 1 contact\(s\), mean \|F\| (\d+\.\d\d) N$", out[3])
    assert touching and int(touching.group(1)) > 10 and float(touching.group(2)) > 1.39  # gate
    assert re.match(r"/tactile/sensor0/wrench \[tactile_sensor0\] first force \(.*\) N$", out[4])
    _parquet_block_runs_on_the_same_run(tmp_path)


def _parquet_block_runs_on_the_same_run(cwd):
    """The Parquet section's block, after the example recorded run1 in ``cwd``."""
    text = (ROOT / "docs" / "recordings.md").read_text(encoding="utf-8")
    section = text[text.index("## Parquet") :]
    lines = re.search(r"```sh\n(.*?)```", section, re.S).group(1).strip().splitlines()
    assert len(lines) == 2 and all(line.startswith(".venv/bin/") for line in lines)
    for line in lines:
        r = subprocess.run(line, shell=True, cwd=cwd, capture_output=True, text=True)
        assert r.returncode == 0 and r.stderr == "", (line, r.stderr)
    assert (cwd / "run1" / "run1.parquet").stat().st_size > 0
    assert re.fullmatch(r"\d+ frames, fx_N in N\n", r.stdout), r.stdout
