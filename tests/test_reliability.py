"""Every hostile-world probe of ``bench/reliability_*.py`` holds (issue 12): the table in
docs/reliability.md is produced by the same code this test runs."""

import sys

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "bench"))
import reliability  # noqa: E402


@pytest.mark.slow
@pytest.mark.parametrize("area", reliability.areas())
def test_every_probe_holds(area):
    title, rows = reliability.run_area(area)
    assert rows, f"{area}: no probes"
    failed = [f"{p}: {o}" for p, _, o in rows if o != "held"]
    assert not failed, "\n".join(failed)
