"""The benchmark tables of the documents are those of the results files (no benchmark runs).

``benchmarks/tables.py`` writes the tables of ``benchmarks/README.md`` and the README's
comparison with peers from ``benchmarks/results``; these tests fail when a document is stale
(run ``python benchmarks/tables.py``) or the results folder holds more than one file per
benchmark script.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
RESULTS = BENCHMARKS / "results"


@pytest.fixture(scope="module")
def tables():
    """``benchmarks/tables.py`` as a module (the benchmarks are not a package)."""
    spec = importlib.util.spec_from_file_location("benchmark_tables", BENCHMARKS / "tables.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_no_more_results_files_than_benchmark_scripts():
    scripts = sorted(BENCHMARKS.glob("bench_*.py"))
    files = [p for p in RESULTS.iterdir() if not p.name.startswith(".")]
    assert scripts
    assert len(files) <= len(scripts), sorted(p.name for p in files)


def test_each_results_file_belongs_to_a_script_and_names_its_machine():
    scripts = {p.stem.removeprefix("bench_") for p in BENCHMARKS.glob("bench_*.py")}
    for path in RESULTS.iterdir():
        if path.name.startswith("."):
            continue
        assert path.suffix == ".json" and path.stem in scripts, path.name
        record = json.loads(path.read_text(encoding="utf-8"))
        assert record["benchmark"] == path.stem
        assert record["command"].strip()
        machine = record["machine"]
        for key in ("cpu", "cores", "os", "python", "packages", "date"):
            assert key in machine, (path.name, key)


def test_the_results_folder_is_as_the_generator_expects(tables):
    assert tables.problems() == []


def test_documents_show_the_results(tables):
    for path, text in tables.documents().items():
        stale = path.read_text(encoding="utf-8") != text
        assert not stale, f"{path.name} is stale: run python benchmarks/tables.py"


def test_every_benchmark_has_its_table_in_benchmarks_readme(tables):
    readme = (BENCHMARKS / "README.md").read_text(encoding="utf-8")
    for name in tables.TABLES:
        assert f"<!-- results: {name} -->" in readme
        assert f"`bench_{name}.py`" in readme
