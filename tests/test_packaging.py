"""Packaging (issue 15): ``python -m tactile`` is the CLI, the distribution name is not
PyPI's unrelated ``tactile``, every install hint names our distribution, and the licence
and citation files the pyproject promises exist."""

import re
import subprocess
import sys
import tomllib

from conftest import ROOT


def test_python_m_tactile_runs_the_cli():
    r = subprocess.run(
        [sys.executable, "-m", "tactile", "--version"], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 0 and r.stdout.startswith("tactile "), (r.stdout, r.stderr)


def test_distribution_name_and_install_hints_agree():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert meta["name"] == "tactile-shape"
    extras = set(meta["optional-dependencies"])
    files = [*ROOT.glob("host/**/*.py"), *ROOT.glob("studies/**/*.py"), *ROOT.glob("docs/*.md")]
    files.append(ROOT / "README.md")
    hints = [
        m for f in files for m in re.findall(r"pip install '([\w-]+)\[(\w+)\]'", f.read_text())
    ]
    assert hints, "no install hint found"
    assert all(name == meta["name"] and extra in extras for name, extra in hints), hints


def test_licence_and_citation_exist():
    assert "MIT License" in (ROOT / "LICENSE").read_text()
    cff = (ROOT / "CITATION.cff").read_text()
    assert "cff-version" in cff and "Exploring the shape of objects" in cff


def test_the_installed_entry_points_are_the_pyprojects():
    """Packages add commands and port schemes through entry points (tactile.commands); an
    install older than pyproject.toml lacks them.  make reinstalls when pyproject.toml is
    newer than its stamp."""
    from importlib.metadata import distribution

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert {"tactile.commands", "tactile.ports"} <= set(declared)
    found = distribution("tactile-shape").entry_points
    installed = {g: {e.name: e.value for e in found if e.group == g} for g in declared}
    assert installed == declared, "an old install: run make (pip install -e '.[test]')"
    assert "$(STAMP): pyproject.toml" in (ROOT / "Makefile").read_text()
