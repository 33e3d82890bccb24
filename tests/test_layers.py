"""Layers run one way (issue 15): protocol -> firmware -> host library -> simulator ->
application.  The host library (``tactile`` outside ``tactile.cli``) never imports the
simulator, neither at module level nor inside a function; the application layer
(``tactile.cli``: the CLI, the chapter 5 replica, the demo, sim:// ports) may."""

import ast
import subprocess
import sys

from conftest import ROOT

LIBRARY = ROOT / "host" / "tactile"


def _imports(path):
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((node.lineno, a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.lineno, node.module


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


def test_a_sim_port_without_the_simulator_registered_says_how_in_one_line():
    code = (
        "from tactile.serial_port import open_port\n"
        "from tactile.errors import InputError\n"
        "try:\n    open_port('sim://press')\n"
        "except InputError as e:\n    print(e)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "tactile_sim.urlhandler.register()" in r.stdout, r
