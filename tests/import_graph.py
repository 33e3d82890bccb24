"""The product code's modules and their imports, read from the source (``ast``), for the
layer tests: module-level and function-level imports alike.

An import names the module it reaches: ``from tactile.calib import ati`` reaches the module
``tactile.calib.ati``, ``from tactile.errors import InputError`` reaches ``tactile.errors``
and ``from tactile import units`` the module ``tactile.units``.  The packages a module sits
in are not counted as its imports (as import-linter counts them), so a package's
``__init__`` is an import only where it is named (``from tactile.ep2 import analyze_patch``).
"""

import ast
import functools
from typing import NamedTuple

from conftest import ROOT

# import name -> folder: the five packages, one per folder
PACKAGES = {
    "tactile_protocol": "protocol",
    "tactile_fw": "firmware",
    "tactile": "host",
    "tactile_sim": "sim",
    "tactile_studies": "studies",
}


class Import(NamedTuple):
    module: str  # the importing module
    path: str  # its file, from the repository's root
    line: int
    function: str | None  # the qualified name of the function it runs in; None: module level
    said: str  # the module as the statement names it: "tactile.ep1" in "from tactile.ep1 import x"
    target: str  # the project's module it reaches


def modules():
    """module name -> file, of every module of the five packages."""
    found = {}
    for package, folder in PACKAGES.items():
        for path in sorted((ROOT / folder / package).rglob("*.py")):
            parts = path.relative_to(ROOT / folder).with_suffix("").parts
            found[".".join(parts).removesuffix(".__init__")] = path
    return found


def product_files():
    """Every Python file of product code: the packages and the tools beside them."""
    return sorted(p for folder in set(PACKAGES.values()) for p in (ROOT / folder).rglob("*.py"))


def imports(files=None):
    """Every import of a project module in ``files`` (default: the packages' modules, read
    once per process: the tests that ask only read them)."""
    return _read(files) if files else list(_packages())


@functools.cache
def _packages():
    return _read(None)


def _read(files):
    known = modules()
    names = {path: name for name, path in known.items()}
    out = []
    for path in files or known.values():
        name = names.get(path, path.stem)
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        out.extend(_walk(tree, name, path, path.name == "__init__.py", known, ()))
    return out


def _walk(node, name, path, is_package, known, scope):
    for child in ast.iter_child_nodes(node):
        inner = scope
        if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            inner = (*scope, (child.name, not isinstance(child, ast.ClassDef)))
        elif isinstance(child, ast.Import | ast.ImportFrom):
            function = ".".join(n for n, _ in scope) if any(f for _, f in scope) else None
            for said, target in _targets(child, name, is_package, known):
                where = str(path.relative_to(ROOT))
                yield Import(name, where, child.lineno, function, said, target)
        yield from _walk(child, name, path, is_package, known, inner)


def _targets(node, name, is_package, known):
    """(module as said, project module reached) of each name an import statement binds."""
    if isinstance(node, ast.Import):
        for alias in node.names:
            if alias.name.split(".")[0] in PACKAGES:
                yield alias.name, _module(alias.name, known)
        return
    said = node.module or ""
    if node.level:
        here = name.split(".") if is_package else name.split(".")[:-1]
        said = ".".join(
            [*here[: len(here) - node.level + 1], *([node.module] if node.module else [])]
        )
    if said.split(".")[0] not in PACKAGES:
        return
    for alias in node.names:
        yield said, _module(f"{said}.{alias.name}", known)


def _module(name, known):
    """The longest prefix of dotted ``name`` that is a module."""
    while name not in known and "." in name:
        name = name.rpartition(".")[0]
    return name


def graph(found):
    """module -> the set of modules it imports, from ``found`` (``imports()``)."""
    edges = {}
    for i in found:
        if i.target != i.module:
            edges.setdefault(i.module, set()).add(i.target)
    return edges


def cycles(edges):
    """The strongly connected components of more than one module, each sorted (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found
