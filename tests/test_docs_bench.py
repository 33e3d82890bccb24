"""docs/bench.md lists every benchmark in bench/: each script that makes a figure has a row
naming it, what it measures and the doc that holds its table.  The scripts that make no
figure of their own (shared helpers, the payload bench's synthetic recordings) are named in
the page's prose, and ``reliability_*.py`` by the row of ``reliability.py``."""

import re

from conftest import ROOT

BENCH = ROOT / "bench"
PAGE = ROOT / "docs" / "bench.md"
HELPERS = {"timing.py", "bench_args.py", "payload_synth.py"}  # no figure of their own


def _rows():
    """The script names in the first cell of each table row of docs/bench.md."""
    text = PAGE.read_text(encoding="utf-8")
    return {
        name
        for line in text.splitlines()
        if line.startswith("| `")
        for name in re.findall(r"`([a-z_0-9*]+\.py)`", line.split("|")[1])
    }


def test_every_bench_script_has_a_row_naming_its_table():
    rows = _rows()
    scripts = {p.name for p in BENCH.glob("*.py")} - HELPERS
    listed = {
        s
        for s in scripts
        if s in rows or (s.startswith("reliability_") and "reliability_*.py" in rows)
    }
    assert scripts - listed == set(), "bench scripts with no row in docs/bench.md"
    assert rows - scripts - {"reliability_*.py"} == set(), "rows naming no script in bench/"


def test_the_helpers_are_named_in_the_prose():
    text = PAGE.read_text(encoding="utf-8")
    for helper in HELPERS:
        assert f"`{helper}`" in text, helper


def test_every_held_out_split_is_refused_without_final():
    """A bench's held-out split is kept unseen until the final run: each bench that has
    one refuses it without ``--final`` in argparse's one line (exit 2), before any work."""
    import subprocess
    import sys

    for script, split in [("ep2_edges.py", "holdout"), ("ep2_families.py", "robust_holdout"),
                          ("ep2_map.py", "holdout"), ("explore.py", "holdout"),
                          ("explore_bound.py", "holdout")]:  # fmt: skip
        r = subprocess.run([sys.executable, str(ROOT / "bench" / script), "--split", split],
                           capture_output=True, text=True, timeout=60)  # fmt: skip
        assert r.returncode == 2 and "add --final" in r.stderr, (script, r.stderr)
