"""Shared test fixtures: paths and a CLI runner that captures output and exit code."""

import json
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def vectors():
    return json.loads((ROOT / "protocol" / "vectors.json").read_text())


@pytest.fixture
def cli(capsys):
    """Run ``tactile ARGS...`` in-process; return (exit code, stdout, stderr)."""
    from tactile.cli.main import main

    def run(*args):
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return code, out, err

    return run
