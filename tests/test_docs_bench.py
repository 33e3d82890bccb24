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
