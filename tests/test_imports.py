"""Static import rules, read from the source with ``ast`` (nothing is imported).

* no import cycle between the modules of ``spline/``, ``param/`` and ``fit/``, counting the
  imports inside functions too (two modules that need each other are one idea in two homes);
  only ``if TYPE_CHECKING:`` blocks, which never run, are left out;
* no import of a private module (a path component starting with ``_``, such as
  ``trispline.param._igl``) from another layer, or from tests, examples or benchmarks; no
  import of a private name (``from trispline.param.validate import _raise``) from another
  layer's module;
* layering: ``trispline.spline`` imports neither ``trispline.param`` nor ``trispline.fit``, and
  ``trispline.param`` does not import ``trispline.fit`` (anywhere in the file, lazy imports too);
* every imported project module exists (so that a misspelt or stale import cannot slip past
  the rules above).
"""
from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Source folder -> import name, in layer order (a layer may import only the ones before it).
LAYERS = {"spline": "trispline.spline", "param": "trispline.param", "fit": "trispline.fit"}
#: What each layer must not import.
BANNED = {"trispline.spline": ("trispline.param", "trispline.fit"), "trispline.param": ("trispline.fit",)}
#: Folders whose scripts and tests use the package from outside.
OUTSIDE = ("tests", "examples", "benchmarks")


@dataclass(frozen=True)
class Import:
    """One imported project module (or name of a module) of one source file."""

    source: str  # importer: its module name, or for tests/examples its path relative to ROOT
    target: str  # fully qualified module (for ``from M import n``: ``M.n`` if that is a module, else ``M``)
    name: str | None  # the imported name of ``from M import name`` when it is not a module
    line: int
    typing_only: bool  # under ``if TYPE_CHECKING:``, never executed

    def where(self) -> str:
        return f"{self.source}:{self.line} imports {self.target}" + (f".{self.name}" if self.name else "")


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT)
    parts = [LAYERS[rel.parts[0]], *rel.parts[1:-1]]
    if path.stem != "__init__":
        parts.append(path.stem)
    return ".".join(parts)


#: Every module of the three layers: name -> file.
MODULES = {_module_name(p): p for folder in LAYERS for p in sorted((ROOT / folder).rglob("*.py"))}


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _walk(node: ast.AST, typing_only: bool) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement under ``node``, with whether it sits under ``if TYPE_CHECKING:``."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.Import, ast.ImportFrom)):
            yield child, typing_only
        elif isinstance(child, ast.If) and _is_type_checking(child.test):
            yield from _walk(child, True)
        else:
            yield from _walk(child, typing_only)


def _resolve_base(node: ast.ImportFrom, module: str | None, is_package: bool) -> str:
    if not node.level:
        return node.module or ""
    assert module is not None, f"relative import outside the package: line {node.lineno}"
    parts = module.split(".")
    base = ".".join(parts[: len(parts) - node.level + (1 if is_package else 0)])
    return f"{base}.{node.module}" if node.module else base


def imports_in(text: str, source: str, module: str | None = None, is_package: bool = False) -> list[Import]:
    """The project imports of one file's ``text``; ``module`` is its name (None outside the layers)."""
    out = []
    for node, typing_only in _walk(ast.parse(text), False):
        if isinstance(node, ast.Import):
            out += [Import(source, alias.name, None, node.lineno, typing_only) for alias in node.names]
            continue
        base = _resolve_base(node, module, is_package)
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            if sub in MODULES:
                out.append(Import(source, sub, None, node.lineno, typing_only))
            else:
                out.append(Import(source, base, None if alias.name == "*" else alias.name, node.lineno, typing_only))
    return [i for i in out if i.target.startswith("trispline.")]


def imports_of(path: Path) -> list[Import]:
    """The project imports of the file ``path`` (a layer module, test, example or benchmark)."""
    rel = path.relative_to(ROOT)
    module = _module_name(path) if rel.parts[0] in LAYERS else None
    return imports_in(path.read_text(encoding="utf-8"), module or str(rel), module, path.stem == "__init__")


def _layer_of(name: str) -> str | None:
    return next((layer for layer in LAYERS.values() if name == layer or name.startswith(layer + ".")), None)


def _is_private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


# ------------------------------------------------------------------------- the rules
def missing_modules(imports: list[Import]) -> list[str]:
    return sorted({i.where() for i in imports if i.target not in MODULES})


def cycles(imports: list[Import]) -> list[list[str]]:
    """Import cycles: strongly connected components of more than one module (Tarjan)."""
    edges: dict[str, set[str]] = {}
    for i in imports:
        if not i.typing_only and i.target != i.source:
            edges.setdefault(i.source, set()).add(i.target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = stack[stack.index(v):]
            del stack[stack.index(v):]
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def private_module_imports(imports: list[Import]) -> list[str]:
    """Private modules imported from another layer, or from outside the layers."""
    return sorted(i.where() for i in imports
                  if any(_is_private(p) for p in i.target.split(".")[2:])
                  and _layer_of(i.source) != _layer_of(i.target))


def private_name_imports(imports: list[Import]) -> list[str]:
    """Private names imported by a layer module from another layer."""
    return sorted(i.where() for i in imports
                  if i.name is not None and _is_private(i.name) and _layer_of(i.source) is not None
                  and _layer_of(i.source) != _layer_of(i.target))


def layer_violations(imports: list[Import]) -> list[str]:
    """Imports against the layer order (spline <- param <- fit)."""
    return sorted(i.where() for i in imports if _layer_of(i.target) in BANNED.get(_layer_of(i.source), ()))


# ------------------------------------------------------------------------- the tests
@pytest.fixture(scope="module")
def layer_imports() -> list[Import]:
    return [i for p in MODULES.values() for i in imports_of(p)]


@pytest.fixture(scope="module")
def outside_imports() -> list[Import]:
    files = [p for folder in OUTSIDE if (ROOT / folder).is_dir() for p in sorted((ROOT / folder).rglob("*.py"))]
    return [i for p in files for i in imports_of(p)]


def test_sources_are_found(layer_imports):
    assert {"trispline.spline.topology", "trispline.param", "trispline.fit.cli"} <= set(MODULES)
    assert len(layer_imports) > 100


def test_every_imported_module_exists(layer_imports, outside_imports):
    missing = missing_modules(layer_imports + outside_imports)
    assert not missing, "imports of modules that do not exist:\n" + "\n".join(missing)


def test_no_import_cycle(layer_imports):
    found = cycles(layer_imports)
    assert not found, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_no_private_module_from_another_layer_or_outside(layer_imports, outside_imports):
    bad = private_module_imports(layer_imports + outside_imports)
    assert not bad, "private modules imported from another layer or from outside:\n" + "\n".join(bad)


def test_no_private_name_from_another_layer(layer_imports):
    bad = private_name_imports(layer_imports)
    assert not bad, "private names imported from another layer:\n" + "\n".join(bad)


def test_layers_import_one_way(layer_imports):
    bad = layer_violations(layer_imports)
    assert not bad, "imports against the layer order spline <- param <- fit:\n" + "\n".join(bad)


def test_the_rules_see_violations():
    """Negative control: each rule flags a made-up module that breaks it."""
    text = ("from trispline.param import _igl\n"            # a private module, another layer
            "from trispline.param.validate import _orient\n"  # a private name, another layer
            "from . import topology\n"                        # spline.topology
            "if TYPE_CHECKING:\n    import trispline.spline.edit\n"
            "def lazy():\n    import trispline.fit.cli\n"    # against the layer order, even lazily
            "import trispline.spline.nothere\n")
    imps = imports_in(text, "trispline.spline.surface", "trispline.spline.surface")
    assert private_module_imports(imps) == ["trispline.spline.surface:1 imports trispline.param._igl"]
    assert private_name_imports(imps) == ["trispline.spline.surface:2 imports trispline.param.validate._orient"]
    assert layer_violations(imps) == [
        "trispline.spline.surface:1 imports trispline.param._igl",
        "trispline.spline.surface:2 imports trispline.param.validate._orient",
        "trispline.spline.surface:7 imports trispline.fit.cli"]
    assert missing_modules(imps) == ["trispline.spline.surface:8 imports trispline.spline.nothere"]
    assert [i.target for i in imps if i.typing_only] == ["trispline.spline.edit"]
    assert imps[2].target == "trispline.spline.topology"
    tests = imports_in("from trispline.spline.util import gather\nimport trispline.param._igl\n", "tests/t.py")
    assert private_module_imports(tests) == ["tests/t.py:2 imports trispline.param._igl"]
    ring = [Import("a", "b", None, 1, False), Import("b", "c", None, 1, False), Import("c", "a", None, 1, False),
            Import("d", "a", None, 1, False), Import("c", "d", None, 1, True)]
    assert cycles(ring) == [["a", "b", "c"]]
    assert cycles(ring[:2]) == []
