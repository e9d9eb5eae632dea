"""The house as docs/architecture.rst describes it: its packages and layers, measured from the
code's own imports and definitions (nothing is imported or run here)."""

from __future__ import annotations

import ast
import re
import subprocess
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "brdfkit"
ARCHITECTURE = ROOT / "docs" / "architecture.rst"

MAX_TOP_MODULES = 12
MAX_FUNCTION_LINES = 200
NUMBA_INTERNALS = "brdfkit.compiled._numba"


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(SRC.parent).with_suffix("").parts).removesuffix(".__init__")


@cache
def _modules() -> dict[str, ast.Module]:
    return {_module_name(p): ast.parse(p.read_text(encoding="utf-8")) for p in SRC.rglob("*.py")}


def _unit(module: str) -> str:
    """The package (``brdfkit.render``) or top-level module (``brdfkit.io``) a module is in."""
    parts = module.split(".")
    return ".".join(parts[:2])


def _imports(tree: ast.Module) -> list[tuple[str, str]]:
    """``(module, name)`` of every ``brdfkit`` import in a module, at any depth (lazy imports
    inside functions included); ``name`` is ``""`` for ``import brdfkit.x``."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "brdfkit" or node.module.startswith("brdfkit."):
                found += [(node.module, alias.name) for alias in node.names]
        elif isinstance(node, ast.Import):
            found += [(a.name, "") for a in node.names if a.name.startswith("brdfkit.")]
    return found


def _target(module: str, name: str) -> str:
    """The module an import reaches: ``from brdfkit.render import shading`` reaches the
    submodule, ``from brdfkit.render import shade`` the package."""
    candidate = f"{module}.{name}" if name else module
    return candidate if candidate in _modules() else module


def _edges() -> set[tuple[str, str]]:
    edges = set()
    for module, tree in _modules().items():
        for imported, name in _imports(tree):
            edges.add((module, _target(imported, name)))
    return edges


@cache
def _layers() -> dict[str, int]:
    """``{"brdfkit.render": 6, ...}`` from the layer table of docs/architecture.rst."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    table = text.split(".. list-table:: Layers", 1)[1].split("\n\n\n", 1)[0]
    layers = {}
    for row in re.split(r"\n   \* - ", table)[2:]:  # the options and the header row first
        cells = re.split(r"\n     - ", row)
        for name in re.findall(r"``(\w+)``", cells[1]):
            layers[f"brdfkit.{name}"] = int(cells[0])
    return layers


def test_the_layer_table_lists_every_package_and_top_level_module():
    units = {_unit(m) for m in _modules() if m != "brdfkit"}
    assert units == set(_layers())


def test_at_most_twelve_modules_at_the_top():
    top = sorted(p.name for p in SRC.glob("*.py"))
    assert len(top) <= MAX_TOP_MODULES, top


def test_lower_layers_never_import_higher_ones():
    layers = _layers()
    upward = sorted(
        (a, b)
        for a, b in _edges()
        if _unit(a) != _unit(b) and b != "brdfkit" and layers[_unit(b)] >= layers[_unit(a)]
    )
    assert upward == []


def test_no_import_circles():
    graph: dict[str, set[str]] = {}
    for a, b in _edges():
        if a != b and b in _modules():
            graph.setdefault(a, set()).add(b)
    index, low, stack, on_stack, circles = {}, {}, [], set(), []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert circles == []


def _home(imported: str, name: str) -> str | None:
    """The package a private import belongs to, or ``None`` for a public one: a module with a
    leading underscore belongs to its parent package (``brdfkit._array`` to all of brdfkit), a
    private name to the package of its module (a top-level module keeps its own)."""
    target = _target(imported, name)
    parts = target.split(".")
    for i, part in enumerate(parts[1:], start=1):
        if part.startswith("_") and not part.startswith("__"):
            return ".".join(parts[:i])
    if target == imported and name.startswith("_") and not name.startswith("__"):
        return (
            _unit(imported)
            if _unit(imported) != imported or imported not in _modules()
            else imported
        )
    return None


def test_private_names_stay_in_the_package_that_defines_them():
    """A name or module with a leading underscore is imported only from inside the package
    that holds it (``brdfkit._array`` and ``brdfkit._checks``, at the top, are the library's)."""
    crossing = []
    for module, tree in _modules().items():
        for imported, name in _imports(tree):
            home = _home(imported, name)
            if home is not None and not (module + ".").startswith(home + "."):
                crossing.append((module, imported, name))
    assert sorted(crossing) == []


def test_no_function_longer_than_two_hundred_lines():
    long = [
        (module, node.name, node.end_lineno - node.lineno + 1)
        for module, tree in _modules().items()
        for node in ast.walk(tree)
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert long == []


INTERNALS = re.compile(
    r"\bnumba\.core\b|\bfrom numba\.core\b|\bllvmlite\b|\bcgutils\b|\b_nrt\b|\._cache\s*="
    r"|\bnumba\.misc\b|\bnumba\.np\b"
)


def test_numba_and_llvmlite_internals_live_in_one_module():
    users = sorted(
        _module_name(path)
        for path in SRC.rglob("*.py")
        if INTERNALS.search(path.read_text(encoding="utf-8"))
    )
    assert users == [NUMBA_INTERNALS]


def test_library_code_never_imports_tests_or_oracle_helpers():
    oracle = [
        (module, target)
        for module, target in _edges()
        if target.startswith("brdfkit.interop.mitsuba") and not module.startswith("brdfkit.interop")
    ]
    tests = [
        (module, imported)
        for module, tree in _modules().items()
        for imported, _ in _imports(tree)
        if imported.startswith(("tests", "conftest", "benchmarks"))
    ]
    assert oracle == [] and tests == []


LABELS = re.compile(
    r"\b(session ?\d+|issue #?\d+|h(atlas|quad|env|aniso|ps)\d*\b|psfast|bivariate3)"
    r"|(?<![\w&])#\d{2}\b",
    re.IGNORECASE,
)


THIS_FILE = "tests/test_architecture.py"  # it spells the labels out


def test_no_lab_notebook_labels_in_tracked_files():
    """No work-log labels, helper or branch names, or issue numbers in the repository."""
    files = subprocess.run(
        ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    hits = []
    for name in files:
        path = ROOT / name
        if path.suffix not in {".py", ".md", ".rst", ".toml", ".txt", ".js", ".json", ".cfg", ""}:
            continue
        if not path.is_file() or path.stat().st_size > 2_000_000 or name == THIS_FILE:
            continue
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if LABELS.search(line):
                hits.append(f"{name}:{number}: {line.strip()[:80]}")
    assert hits == []


def test_the_readme_is_for_users():
    assert len((ROOT / "README.md").read_text(encoding="utf-8").splitlines()) <= 250


def test_one_results_file_per_benchmark():
    benchmarks = list((ROOT / "benchmarks").glob("bench_*.py"))
    results = [p for p in (ROOT / "benchmarks" / "results").iterdir() if p.is_file()]
    assert len(results) <= len(benchmarks)


def _doctest_lines(tree: ast.Module) -> int:
    count = 0
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            doc = ast.get_docstring(node, clean=True) or ""
            count += sum(1 for line in doc.splitlines() if line.lstrip().startswith(">>> "))
    return count


def test_docstrings_hold_examples_that_run():
    """At least a hundred lines of doctest in the library (CI runs them:
    ``pytest --doctest-modules src``)."""
    assert sum(_doctest_lines(tree) for tree in _modules().values()) >= 100


@pytest.mark.parametrize("package", ["brdf", "light", "render", "compiled", "fit", "checks"])
def test_each_package_declares_its_public_api(package):
    init = _modules()[f"brdfkit.{package}"]
    assigned = {
        target.id
        for node in init.body
        if isinstance(node, ast.Assign)
        for target in node.targets
        if isinstance(target, ast.Name)
    }
    assert "__all__" in assigned
