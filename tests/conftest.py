"""Shared test fixtures: paths and a CLI runner that captures output and exit code."""

import json
import os
import pathlib

import pytest
from hypothesis import HealthCheck, settings

from tactile_sim.urlhandler import register as register_sim_ports

# Fuzzing campaigns (issue 12): fixed seed and a bounded budget in CI; a long, randomised
# run locally with TACTILE_FUZZ=long (tests read FUZZ_EXAMPLES for their own budget).
settings.register_profile(
    "ci",
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "long",
    derandomize=False,
    deadline=None,
    max_examples=20_000,
    suppress_health_check=[HealthCheck.too_slow],
)
FUZZ = os.environ.get("TACTILE_FUZZ", "ci")
settings.load_profile("long" if FUZZ == "long" else "ci")
FUZZ_SCALE = 50 if FUZZ == "long" else 1  # multiply a campaign's CI example count by this

ROOT = pathlib.Path(__file__).resolve().parents[1]

# The tests are the application layer here: they serve sim:// ports as the CLI does
# (the library never imports the simulator itself, tests/test_layers.py).
register_sim_ports()


def load_bench(name):
    """A script of ``bench/`` as a module (its estimators and rules, not a copy of them)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "bench" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


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


@pytest.fixture(scope="session")
def ccore_lib(tmp_path_factory):
    """The C firmware core (firmware/c), built by ``cc`` for this run and loaded by ctypes."""
    from ccore_twin import build_or_skip

    from tactile_fw.host_only import ccore

    return ccore.load(build_or_skip(tmp_path_factory.mktemp("ccore")))
