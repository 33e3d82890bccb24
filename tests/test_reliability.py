"""Every hostile-world probe of ``bench/reliability_*.py`` holds (issue 12): the table in
docs/reliability.md is produced by the same code this test runs.  A probe whose module
gives it to dedicated tests (``COVERED``) is left to them here, and those tests must
exist; ``bench/reliability.py`` still runs every probe for the table."""

import ast
import sys

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "bench"))
import reliability  # noqa: E402


@pytest.mark.slow
@pytest.mark.parametrize("area", reliability.areas())
def test_every_probe_holds(area):
    title, rows = reliability.run_area(area, covered=False)
    assert rows, f"{area}: no probes"
    failed = [f"{p}: {o}" for p, _, o in rows if o != "held"]
    assert not failed, "\n".join(failed)


def _tests_in(path):
    """The names of the test functions defined at the top of ``path``."""
    tree = ast.parse((ROOT / path).read_text(encoding="utf-8"))
    return {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}


@pytest.mark.parametrize("area", reliability.areas())
def test_a_probe_left_out_names_tests_that_exist(area):
    mod = reliability.module(area)
    for probe, tests in getattr(mod, "COVERED", {}).items():
        assert callable(getattr(mod, probe, None)), f"{area}: no probe {probe}"
        assert tests, f"{area}: {probe} names no test"
        for test in tests:
            path, _, name = test.partition("::")
            assert name in _tests_in(path), f"{area}: {probe}: no {test}"
