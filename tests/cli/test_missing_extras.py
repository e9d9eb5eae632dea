"""An optional part whose extra is not installed: one line naming the extra, exit 2.

Each test blocks a package (``sys.modules[name] = None`` makes ``import name`` fail as if it
were not installed) and runs a command or a library call that needs it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.errors import EXTRAS, MissingExtraError, require_extra

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def _one_line_naming(result, command: str, module: str, extra: str) -> None:
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [
        f"error: `brdfkit {command}` needs the {extra!r} extra ({module} is not installed): "
        f"pip install 'brdfkit[{extra}]'"
    ]


def test_explore_without_starlette_in_a_fresh_process(tmp_path):
    blocked = "import sys; sys.modules['starlette'] = None; from brdfkit.cli import main; main()"
    done = subprocess.run(
        [sys.executable, "-c", blocked, "explore", "--no-browser"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        cwd=tmp_path,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        "error: `brdfkit explore` needs the 'explore' extra (starlette is not installed): "
        "pip install 'brdfkit[explore]'"
    ]
    assert "internal error" not in done.stderr and done.stdout == ""


@pytest.mark.parametrize(
    ("module", "to", "extra"),
    [("pygltflib", "gltf", "gltf"), ("MaterialX", "mtlx", "materialx")],
)
def test_export_without_its_package(tmp_path, monkeypatch, module, to, extra):
    monkeypatch.setitem(sys.modules, module, None)
    out = tmp_path / f"out.{'glb' if to == 'gltf' else 'mtlx'}"
    result = runner.invoke(app, ["export", "ggx(alpha=0.3)", "--to", to, "-o", str(out)])
    _one_line_naming(result, "export", module, extra)
    assert not out.exists()


def test_a_package_imported_without_require_extra_is_named_too(monkeypatch):
    """The command line's net: a ModuleNotFoundError for a package of EXTRAS names its extra."""
    from brdfkit.cli import _app

    monkeypatch.setitem(sys.modules, "torch", None)

    def needs_torch():
        import torch  # noqa: F401

    assert _app._outcome(needs_torch, "`brdfkit x`") == 2

    def needs_nothing_known():
        import brdfkit_no_such_module  # noqa: F401

    assert _app._outcome(needs_nothing_known, "`brdfkit x`") == 3  # a bug, not an extra


def test_library_calls_raise_the_same_error(monkeypatch):
    from brdfkit import load
    from brdfkit.interop.gltf import gltf_document

    monkeypatch.setitem(sys.modules, "pygltflib", None)
    with pytest.raises(MissingExtraError) as info:
        gltf_document(load("ggx(alpha=0.3)"))
    assert isinstance(info.value, ImportError) and info.value.extra == "gltf"
    assert str(info.value) == (
        "this needs the 'gltf' extra (pygltflib is not installed): pip install 'brdfkit[gltf]'"
    )


def test_every_extra_named_is_an_extra_of_the_project():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = declared["optional-dependencies"]
    for module, extra in EXTRAS.items():
        assert extra in extras, (module, extra)
    assert require_extra("json").__name__ == "json"
