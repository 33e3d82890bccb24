"""Layers run one way (issue 15): protocol -> firmware -> host library -> simulator ->
application.  The host library (``tactile`` outside ``tactile.cli``) never imports the
simulator, neither at module level nor inside a function; the simulator never imports the
host's estimators (``tactile.ep1``, ``tactile.ep2``, ``tactile.localize``), and the emulator
checks the host with parts of its own: the vocabulary both need (errors, board settings) is
the protocol's, the robot-log format is ``tactile.logs``, below the estimators; the
application layer
(``tactile.cli`` and the studies ``tactile_studies``: the CLI, the thesis's studies, the
chapter 5 replica, the demo, sim:// ports) may import both, and nothing below imports it."""

import ast
import subprocess
import sys

from conftest import ROOT

LIBRARY = ROOT / "host" / "tactile"
SIMULATOR = ROOT / "sim" / "tactile_sim"
ESTIMATORS = ("tactile.ep1", "tactile.ep2", "tactile.localize")


def _imports(path):
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((node.lineno, a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.lineno, node.module
            # ``from tactile import ep2`` imports the package tactile.ep2
            yield from ((node.lineno, f"{node.module}.{a.name}") for a in node.names)


def _library_files():
    return [p for p in LIBRARY.rglob("*.py") if "cli" not in p.relative_to(LIBRARY).parts]


def test_the_library_never_imports_the_simulator():
    files = _library_files()
    assert len(files) > 40
    bad = [
        f"{p.relative_to(ROOT)}:{line}: {name}"
        for p in files
        for line, name in _imports(p)
        if name.split(".")[0] == "tactile_sim"
    ]
    assert not bad, bad


def test_every_library_module_imports_with_the_simulator_absent():
    modules = sorted(
        ".".join(("tactile", *p.relative_to(LIBRARY).with_suffix("").parts)).removesuffix(
            ".__init__"
        )
        for p in _library_files()
        if p.name != "__main__.py"
    )
    code = (
        "import importlib, sys\n"
        "sys.modules['tactile_sim'] = None  # any import of it fails\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]


def _is(name, package):
    return name == package or name.startswith(package + ".")


def test_the_simulator_never_imports_the_hosts_estimators():
    files = list(SIMULATOR.rglob("*.py"))
    assert len(files) > 30
    bad = [
        f"{p.relative_to(ROOT)}:{line}: {name}"
        for p in files
        for line, name in _imports(p)
        if any(_is(name, e) for e in ESTIMATORS)
    ]
    assert not bad, bad


def test_every_simulator_module_imports_with_the_estimators_absent():
    modules = sorted(
        ".".join(("tactile_sim", *p.relative_to(SIMULATOR).with_suffix("").parts)).removesuffix(
            ".__init__"
        )
        for p in SIMULATOR.rglob("*.py")
        if p.name != "__main__.py"
    )
    code = (
        "import importlib, sys\n"
        f"for gone in {ESTIMATORS + ('tactile_studies',)!r}:\n"
        "    sys.modules[gone] = None  # any import of it fails\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]


# What the emulator may take from the host library: the robot-log format and the bounded file
# reader.  Not the host's decoder, board settings or error tree: a bug the emulator shared
# with the host it checks would hide (the vocabulary both need is tactile_protocol's).
EMULATOR_MAY_USE = ("tactile.logs", "tactile.files")
NEVER_IN_THE_SIMULATOR = ("tactile.board.stream_decoder", "tactile.board.settings")


def test_the_emulator_does_not_check_the_host_with_the_hosts_own_parts():
    emulator = list((SIMULATOR / "emulator").rglob("*.py"))
    assert len(emulator) > 20
    bad = [
        f"{p.relative_to(ROOT)}:{line}: {name}"
        for p in emulator
        for line, name in _imports(p)
        if _is(name, "tactile") and not any(_is(name, ok) for ok in EMULATOR_MAY_USE)
    ]
    bad += [
        f"{p.relative_to(ROOT)}:{line}: {name}"
        for p in SIMULATOR.rglob("*.py")
        for line, name in _imports(p)
        if any(_is(name, never) for never in NEVER_IN_THE_SIMULATOR)
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


def test_nothing_below_the_application_imports_the_studies():
    below = [ROOT / "protocol", ROOT / "firmware", SIMULATOR, *_library_files()]
    files = [f for b in below for f in (b.rglob("*.py") if b.is_dir() else [b])]
    assert len(files) > 100
    bad = [
        f"{p.relative_to(ROOT)}:{line}: {name}"
        for p in files
        for line, name in _imports(p)
        if _is(name, "tactile_studies")
    ]
    assert not bad, bad


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
    for package in ("board", "recording", "files", "output"):
        doc = (LIBRARY / package / "__init__.py").read_text(encoding="utf-8")
        assert doc.startswith('"""') and len(doc.splitlines()) >= 3, package
    assert callable(tactile.load_recording) and tactile.__version__
