"""docs/ep2.md's first command block (moved there from the README) runs exactly as written
(issue 11's interface): each line in a fresh directory whose ``.venv`` is this interpreter's
environment, exit 0, one table or JSON record, no traceback, no NaN."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from conftest import ROOT


def _block(heading):
    text = (ROOT / "docs" / "ep2.md").read_text(encoding="utf-8")
    start = text.index(heading)
    return re.search(r"```sh\n(.*?)```", text[start:], re.S).group(1).strip().splitlines()


def test_the_ep2_block_runs_as_written(tmp_path):
    lines = _block("## Usage")
    assert len(lines) >= 4 and all(line.startswith(".venv/bin/tactile ") for line in lines)
    os.symlink(Path(sys.executable).absolute().parents[1], tmp_path / ".venv")  # the venv
    outputs = []
    for line in lines:
        r = subprocess.run(line, shell=True, cwd=tmp_path, capture_output=True, text=True)
        assert r.returncode == 0 and "Traceback" not in r.stderr, (line, r.stderr)
        assert not re.search(r"\b(nan|inf|infinity)\b", r.stdout, re.I), r.stdout
        outputs.append(r.stdout)
    assert (tmp_path / "c.csv").exists()
    records = [json.loads(out) for line, out in zip(lines, outputs) if "--json" in line]
    assert records and all(rec["shape"] == "cylinder" for rec in records)
    tables = [
        out for line, out in zip(lines, outputs) if " analyze " in line and "--json" not in line
    ]
    assert tables and all("cylinder" in out for out in tables)
    for line, out in zip(lines, outputs):  # the sim writes cm; --units mm shows mm
        if " analyze " in line and "--json" not in line:
            unit = "mm" if "--units mm" in line else "cm"
            assert f"radius ({unit})" in out and f"C (R in 1/{unit})" in out, out
