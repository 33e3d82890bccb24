"""Layers run one way: protocol -> firmware -> host library -> simulator -> application.

Every module of the five packages is checked, its module-level and function-level imports
alike (``import_graph``): no import runs up a layer, and no modules import each other in a
circle.  The host library is ``tactile`` but its CLI.  The application is the CLI
(``tactile.cli``, and ``python -m tactile``) and the studies (``tactile_studies``), side by
side: neither imports the other, and the CLI finds the simulator's and the studies'
commands through entry points (``tactile.commands``), never by importing them.  The
simulator never imports the host's estimators, and its emulator checks the host with parts
of its own: the vocabulary both need (errors, board settings) is the protocol's, the
robot-log format is ``tactile.logs``, below the estimators."""

import subprocess
import sys

import pytest
from conftest import ROOT
from import_graph import cycles, graph, imports, modules

LIBRARY = ROOT / "host" / "tactile"
LAYERS = (  # lowest first: (name, the modules in it, by prefix; the longest prefix decides)
    ("protocol", ("tactile_protocol",)),
    ("firmware", ("tactile_fw",)),
    ("host library", ("tactile",)),
    ("simulator", ("tactile_sim",)),
    ("application", ("tactile.cli", "tactile.__main__", "tactile_studies")),
)
CLI = ("tactile.cli", "tactile.__main__")
ESTIMATORS = ("tactile.ep1", "tactile.ep2", "tactile.localize")


def _in(name, prefix):
    return name == prefix or name.startswith(prefix + ".")


def layer_of(module):
    """(index, name) of ``module``'s layer: that of the longest prefix it has."""
    _, index, name = max(
        (len(p), i, n) for i, (n, prefixes) in enumerate(LAYERS) for p in prefixes if _in(module, p)
    )
    return index, name


def upward(found):
    """Each import in ``found`` that reaches a layer above its module's, as a line."""
    return [
        f"{i.path}:{i.line}: {i.module} ({layer_of(i.module)[1]}) imports {i.target}"
        f" ({layer_of(i.target)[1]})"
        for i in found
        if layer_of(i.target)[0] > layer_of(i.module)[0]
    ]


def test_every_package_is_read():
    found = modules()
    for package in ("tactile_protocol", "tactile_fw", "tactile", "tactile_sim", "tactile_studies"):
        assert sum(_in(m, package) for m in found) >= 5, package
    assert any(_in(m, "tactile.cli") for m in found) and len(imports()) > 500


def test_no_import_runs_up_a_layer():
    bad = upward(imports())
    assert not bad, "\n".join(bad)


def test_an_import_up_a_layer_is_found():
    """The check itself: the library serving sim:// ports itself, in a function."""
    port = next(i for i in imports() if i.module == "tactile.board.serial_port")
    assert upward([port._replace(function="open_port", target="tactile_sim.urlhandler")])
    assert upward([port._replace(target="tactile.cli.main")])
    assert not upward([port._replace(target="tactile_protocol.constants")])


def test_the_cli_imports_neither_the_simulator_nor_the_studies():
    bad = [
        f"{i.path}:{i.line}: {i.target}"
        for i in imports()
        if any(_in(i.module, c) for c in CLI)
        and any(_in(i.target, p) for p in ("tactile_sim", "tactile_studies"))
    ]
    bad += [
        f"{i.path}:{i.line}: {i.target}"
        for i in imports()
        if _in(i.module, "tactile_studies") and any(_in(i.target, c) for c in CLI)
    ]
    assert not bad, bad


def test_the_simulator_never_imports_the_hosts_estimators():
    bad = [
        f"{i.path}:{i.line}: {i.target}"
        for i in imports()
        if _in(i.module, "tactile_sim") and any(_in(i.target, e) for e in ESTIMATORS)
    ]
    assert not bad, bad


def test_no_modules_import_each_other_in_a_circle():
    found = cycles(graph(imports()))
    assert not found, f"import cycles: {found}"


def _package(module):
    """``tactile.recording`` of ``tactile.recording.load``; None outside the host library."""
    parts = module.split(".")
    return ".".join(parts[:2]) if parts[0] == "tactile" and len(parts) > 1 else None


def test_no_two_packages_of_the_host_import_each_other_in_a_circle():
    """Each component package of ``tactile`` stands on those below it: the robot logs below
    localisation and EP1, the recording below neither, derive and Foxglove above them."""
    edges = {}
    for i in imports():
        a, b = _package(i.module), _package(i.target)
        if a and b and a != b:
            edges.setdefault(a, set()).add(b)
    assert len(edges) > 10
    assert not cycles(edges)
    above = {"tactile.localize", "tactile.ep1", "tactile.foxglove", "tactile.commands"}
    assert not edges["tactile.logs"] & (above | {"tactile.recording"})
    assert not edges["tactile.recording"] & above


def test_a_cycle_is_found_however_long():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"e"}}
    assert cycles(edges) == [["a", "b", "c"]]  # a module importing itself is no cycle


def _import_all(modules_, absent):
    code = (
        "import importlib, sys\n"
        f"for gone in {absent!r}:\n"
        "    sys.modules[gone] = None  # any import of it fails\n"
        f"for m in {modules_!r}:\n"
        "    importlib.import_module(m)\n"
    )
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(
    "layer, absent",
    [
        (("tactile",), ("tactile_sim", "tactile_studies")),  # the library and the CLI
        (("tactile_sim",), (*ESTIMATORS, "tactile_studies")),
    ],
)
def test_every_module_imports_with_what_is_above_it_absent(layer, absent):
    names = sorted(m for m in modules() if any(_in(m, p) for p in layer))
    names = [m for m in names if not m.endswith("__main__")]
    r = _import_all(names, absent)
    assert r.returncode == 0, r.stderr[-2000:]


def test_without_the_simulator_the_cli_runs_and_says_what_is_missing():
    code = (
        "import sys\n"
        "sys.modules['tactile_sim'] = None\n"
        "from tactile.cli.main import main\n"
        "print(main(['emulate', 'press']))\n"
        "main(['--help'])\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stderr == (
        "tactile emulate: error: 'emulate' is not available in this build: module"
        " tactile_sim.commands is not installed\n"
    )
    first, help_ = r.stdout.split("\n", 1)
    assert first == "1" and "  ports " in help_ and "  emulate " not in help_


# What the emulator may take from the host library: the robot-log format, the robot interface
# its arm implements with that interface's line format (tests/test_robot.py checks the wire
# as raw lines on both sides), the bounded file reader and atomic writer, and the escaping
# of what it prints.  Not the host's decoder, board settings or error tree: a bug the
# emulator shared with the host it checks would hide (the vocabulary both need is
# tactile_protocol's).
EMULATOR_MAY_USE = ("tactile.logs", "tactile.robot", "tactile.files", "tactile.output.text")
NEVER_IN_THE_SIMULATOR = ("tactile.board.stream_decoder", "tactile.board.client")


def test_the_emulator_does_not_check_the_host_with_the_hosts_own_parts():
    found = list(imports())
    emulator = [i for i in found if _in(i.module, "tactile_sim.emulator")]
    assert len({i.module for i in emulator}) > 10
    bad = [
        f"{i.path}:{i.line}: {i.target}"
        for i in emulator
        if _in(i.target, "tactile") and not any(_in(i.target, ok) for ok in EMULATOR_MAY_USE)
    ]
    bad += [
        f"{i.path}:{i.line}: {i.target}"
        for i in found
        if _in(i.module, "tactile_sim") and any(_in(i.target, n) for n in NEVER_IN_THE_SIMULATOR)
    ]
    assert not bad, bad


def test_the_flashed_firmware_package_holds_no_host_only_tooling():
    """Every module of ``tactile_fw`` goes on the board (``tactile flash``'s list): no
    subpackage left behind; the tooling is ``tactile_fw_tools``, which nothing flashes."""
    from tactile.board import flashing

    package = ROOT / "firmware" / "tactile_fw"
    modules = sorted(str(p.relative_to(package.parent)) for p in package.rglob("*.py"))
    flashed = sorted(
        str(src.relative_to(src.parents[1])) for src, _ in flashing.board_files()
        if src.suffix == ".py" and src.parent.name == "tactile_fw"
    )  # fmt: skip
    assert modules == flashed and len(modules) > 10
    assert not any("tactile_fw_tools" in str(src) for src, _ in flashing.board_files())


def test_a_sim_port_without_the_simulator_registered_says_how_in_one_line():
    code = (
        "from tactile.board.serial_port import open_port\n"
        "from tactile.errors import InputError\n"
        "try:\n    open_port('sim://press')\n"
        "except InputError as e:\n    print(e)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "tactile_sim.urlhandler.register()" in r.stdout, r


def test_the_host_package_shows_its_components():
    """At most 12 modules at the top of ``tactile``; the rest in one package per component,
    each saying what it owns; the documented public names importable from ``tactile``."""
    import tactile

    top = sorted(p.name for p in LIBRARY.glob("*.py"))
    assert len(top) <= 12, top
    for package in ("board", "recording", "files", "output", "commands", "logs", "foxglove"):
        doc = (LIBRARY / package / "__init__.py").read_text(encoding="utf-8")
        assert doc.startswith('"""') and len(doc.splitlines()) >= 3, package
    folders = {p.parent for p in LIBRARY.rglob("*.py")} - {LIBRARY}
    assert all((f / "__init__.py").is_file() for f in folders), folders  # packages.find
    assert callable(tactile.load_recording) and tactile.__version__
