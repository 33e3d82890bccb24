"""Function-level imports of the project's own modules in product code: each one is listed
here with why it is not at module level, and the list matches the code exactly (a new one
fails until it is listed with its reason; one that is gone must leave the list).

An import inside a function is for start-up time (a module that every run would load for
the few that need it), or for the board's RAM; never to dodge a layer or to hide an import
cycle (tests/test_layers.py).  A module that is itself loaded only when it is needed (a
command, run by name; a scene's motion, imported by kind; the sim:// handler, loaded by
pyserial for such a port) imports at module level.  At most 30 in all.

Listed by file: ``function: module as the statement names it``, ``(xN)`` when one function
says it N times.
"""

import subprocess
import sys
from collections import Counter

from import_graph import imports, product_files

# Why an import is deferred.
BOARD_RAM = "board code: only the Python core uses it; the C core's board keeps it out of RAM"
SENSOR_RAM = "board code: the ADC driver loads where a sensor is built, not for the constants"
TOOL = "a tool beside the protocol package: checks its vectors with the host's own decoder"
LIGHT_PACKAGE = "'import tactile' stays light: load_recording (NumPy) loads on first use"
FAMILY = (
    "start-up: a family of a group command, imported to build the group's parser (tactile"
    " sim --help); its subcommand's run loads NumPy or SciPy"
)
LIVE_SCENE = (
    "start-up: tactile live imports the server's module; the scene (NumPy, EP2) loads only"
    " for a server given a robot log"
)
LIVE_FIT = (
    "start-up: tactile live imports the server's module; the arrivals' fit (NumPy) loads"
    " only for live --foxglove"
)
LIVE_PAYLOAD = (
    "start-up: tactile live imports its --payload options' module; the tool, the orientations"
    " and the compensator (NumPy, SciPy) load only when a tool is given"
)
SPLINE_SCIPY = "start-up: SciPy loads only when the spline runs (tests/test_ep2_imports.py)"

DEFERRED = {
    "firmware/tactile_fw/frontend.py": {
        "make_sensor: tactile_fw.ads122c04": SENSOR_RAM,
    },
    "firmware/tactile_fw/port_mpy.py": {
        "chip_ceiling: tactile_fw.frontend": BOARD_RAM,
        "make_board: tactile_fw.board": BOARD_RAM,
        "make_board: tactile_fw.frontend": BOARD_RAM,
    },
    "host/tactile/__init__.py": {
        "__getattr__: tactile.payload.apply": LIGHT_PACKAGE,
    },
    "host/tactile/payload/__init__.py": {
        "__getattr__: tactile.payload": LIVE_PAYLOAD,
        "following: tactile.payload.apply": LIVE_PAYLOAD,
        "following: tactile.payload.tool": LIVE_PAYLOAD,
    },
    "host/tactile/foxglove/live.py": {
        "LiveServer.__init__: tactile.foxglove.live_scene": LIVE_SCENE,
        "LiveServer._stamp: tactile.recording.timebase": LIVE_FIT,
    },
    "host/tactile/ep2/api.py": {
        "analyze_patch: tactile.ep2": SPLINE_SCIPY,
    },
    "protocol/make_vectors.py": {
        "decode_case: tactile.board.stream_decoder": TOOL,
    },
    "sim/tactile_sim/commands/sim_ep2.py": {
        "run: tactile_sim.ep2": FAMILY,
        "_map_object: tactile_sim.ep2": FAMILY,
    },
    "studies/tactile_studies/commands/sim_ep1.py": {
        "run: tactile.ep1": FAMILY,
        "run: tactile_sim.ep1.surfaces": FAMILY,
        "run: tactile_studies.ep1.experiment": FAMILY,
    },
    "studies/tactile_studies/commands/study_ep1.py": {
        "_ep1.checked: tactile_studies.ep1": FAMILY,
    },
    "studies/tactile_studies/commands/study_ep2.py": {
        "_study: tactile_studies.ep2": FAMILY,
    },
}


def _found():
    """path::function: module (xN) -> N, of every function-level import statement."""
    said = Counter(
        f"{i.path}::{i.function}: {i.said}"
        for i in {(i.path, i.line): i for i in imports(product_files()) if i.function}.values()
    )
    return {k + (f" (x{n})" if n > 1 else ""): n for k, n in said.items()}


LISTED = {f"{path}::{key}": why for path, keys in DEFERRED.items() for key, why in keys.items()}


def test_each_function_level_import_is_listed_with_its_reason():
    found = _found()
    new = sorted(set(found) - set(LISTED))
    gone = sorted(set(LISTED) - set(found))
    assert not new, "function-level imports to list (with why) or to lift:\n" + "\n".join(new)
    assert not gone, "no longer in the code: take them out of DEFERRED:\n" + "\n".join(gone)


def test_at_most_30_remain():
    assert sum(_found().values()) <= 30, sum(_found().values())


def test_the_cli_defers_no_import():
    """The CLI's commands are imported only when they run (tactile.cli.main), so they
    import their library at module level; the families of a group command are the one
    exception."""
    cli = [k for k in LISTED if k.startswith(("host/tactile/cli/", "host/tactile/commands/"))]
    assert not cli, cli
    commands = [k for k in LISTED if "/commands/" in k.split("::")[0]]
    assert all(LISTED[k] is FAMILY for k in commands), commands


def test_tactile_live_loads_no_numpy_until_a_scene_or_foxglove_needs_it():
    """What LIVE_SCENE and LIVE_FIT defer: lifted, ``tactile live`` would load NumPy."""
    code = (
        "import sys, tactile.cli.cmd_live\n"
        "print(sorted(m for m in ('numpy', 'tactile.ep2') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
