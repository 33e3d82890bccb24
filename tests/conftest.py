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


def _import_every_module():
    """Hypothesis draws constants from every project module loaded when it generates; a
    test's examples then depend on which tests ran before it in its process (xdist, -k).
    Loaded all at once here, the examples are the same however the suite is cut."""
    import importlib
    import pkgutil

    for name in ("tactile_protocol", "tactile_fw", "tactile", "tactile_sim", "tactile_studies"):
        package = importlib.import_module(name)
        for info in pkgutil.walk_packages(package.__path__, name + "."):
            if info.name.endswith("__main__"):
                continue
            try:
                importlib.import_module(info.name)
            except ModuleNotFoundError:  # (the board's own modules: machine, rp2 ...)
                pass


_import_every_module()
settings.load_profile("long" if FUZZ == "long" else "ci")
FUZZ_SCALE = 50 if FUZZ == "long" else 1  # multiply a campaign's CI example count by this

ROOT = pathlib.Path(__file__).resolve().parents[1]

# The tests are the application layer here: they serve sim:// ports as the CLI does
# (the library never imports the simulator itself, tests/test_layers.py).
register_sim_ports()


def load_bench(name):
    """A script of ``bench/`` as a module (its estimators and rules, not a copy of them),
    with ``bench/`` on the import path as when the script runs (its shared helpers)."""
    import importlib.util
    import sys

    if str(ROOT / "bench") not in sys.path:
        sys.path.append(str(ROOT / "bench"))
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

    from tactile_fw_tools import ccore

    return ccore.load(build_or_skip(tmp_path_factory.mktemp("ccore")))


# --- the board suite's targets (tests/board_target.py) ----------------------------------
def pytest_addoption(parser):
    parser.addoption(
        "--port",
        default=None,
        help="a real board's serial port (e.g. /dev/ttyACM0): the board suite runs on it too",
    )


def pytest_collection_modifyitems(config, items):
    """Tests marked ``slow`` first (the order is otherwise kept): under xdist they spread
    over the workers, and a run does not end on one worker finishing a long test alone.
    Without --port, tests marked ``hardware`` are skipped and say why."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
    if config.getoption("--port"):
        return
    from board_target import NO_PORT

    skip = pytest.mark.skip(reason=NO_PORT)
    for item in items:
        if item.get_closest_marker("hardware"):
            item.add_marker(skip)


def _board_targets():
    from board_target import TARGETS

    return TARGETS


@pytest.fixture(params=_board_targets())
def board(request):
    """The board under test: the emulator on the Python or the C core, or --port's board.

    A test that only an emulator can run parametrizes it indirectly with
    ``board_target.EMULATED``.
    """
    from board_target import SERVED, BoardTarget

    if request.param in SERVED:
        return BoardTarget(request.param, request.getfixturevalue("served").port(request.param))
    if request.param == "c":
        from toolchain import missing

        from tactile_sim.emulator import cores

        try:
            cores.c_library()
        except cores.CoreUnavailable as exc:
            missing(str(exc))
    return BoardTarget(request.param, request.config.getoption("--port"))


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory):
    """One ``tactile record`` of the shipped sphere sweep (tests/recorded.py), shared by the
    loader's and both exports' tests: tests write their variants elsewhere."""
    from recorded import record_sweep

    tmp = tmp_path_factory.mktemp("sweep")
    return record_sweep(tmp / "rec", tmp)


@pytest.fixture(scope="session")
def recorded_msgs(recorded_run):
    """The SAMPLE/CONTACT messages of ``recorded_run``'s capture, decoded independently."""
    from recorded import frames_of

    return frames_of(recorded_run)


@pytest.fixture(scope="session")
def served(tmp_path_factory, pico_master):
    """The session's boards served on a pty (board_target.Served: qemu, rp2040)."""
    from board_target import Served

    boards = Served(tmp_path_factory.mktemp("served"), pico_master)
    yield boards
    boards.close()


@pytest.fixture(scope="session")
def pico_master(tmp_path_factory):
    """Where the run's flashed emulated Picos are kept (tests/pico_target.py): one directory
    for every xdist worker, so a run flashes each firmware once, not once per worker."""
    root = tmp_path_factory.getbasetemp()
    folder = (root.parent if os.environ.get("PYTEST_XDIST_WORKER") else root) / "pico-shared"
    folder.mkdir(exist_ok=True)
    return folder


@pytest.fixture
def pico_flashed(pico_master, tmp_path):
    """A flash file of its own holding the firmware for one sensor: an emulated Pico flashed
    as a user flashes one (``pico_target.serve(flash=pico_flashed)`` boots it)."""
    import shutil

    from pico_target import flash_master

    out = tmp_path / "pico.flash"
    shutil.copyfile(flash_master(pico_master), out)
    return out
