"""The plain conversion of command-line values (``brdfkit.cli._plain_values``) gives what
typer's own pydantic conversion gives, on every parameter of every command: the same value of
the same type, or the same error message; and the commands' defaults need no pydantic."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import typer.main

from brdfkit.cli import app
from brdfkit.cli._plain_values import _PlainConverter, engaged, plain_values

ROOT = Path(__file__).resolve().parents[2]

pytest.importorskip("typer._coercion", reason="this typer converts values without pydantic")
if not engaged():
    pytest.skip("plain values are tested with other typer releases", allow_module_level=True)
from typer._click import Context  # noqa: E402
from typer._click.exceptions import BadParameter  # noqa: E402
from typer._coercion import build_runtime_param  # noqa: E402

_GROUP = typer.main.get_group(app)
_COMMANDS = sorted(_GROUP.commands)

_TEXTS = ["abc", "", "ggx(alpha=0.3, material='Au')", "a\udcffb", "-1", "é"]
_INTEGERS = ["12", "8", "8192", "8193", "007", "+12", "-3", " 12", "1_000", "12.0", "1e2",
             "٣", "0x10", "9" * 23, "123456789012345678", 5, 7, 0, True]  # fmt: skip
_FLOATS = ["1.5", "1e3", ".5", "5.", "-0.0", "1e400", "inf", "nan", "1_0.5", " 1.5", "0.1",
           "1e-320", "+2", "64", "65", 3, 2.5, -100.0]  # fmt: skip
_PATHS = ["out.png", "./x/", "a/../b", "//x", "~", "-", "no/such/folder/file.exr"]
_LISTS = [("a", "b"), ["1.5", "2"], ("1.5", "x"), (), ("x",), "single"]


def _inputs(tmp: Path) -> list[object]:
    existing = tmp / "existing.png"
    existing.write_bytes(b"")
    return [*_TEXTS, *_INTEGERS, *_FLOATS, *_PATHS, *_LISTS, str(existing), str(tmp), None, False]


def _outcome(converter: object, value: object, param: object, ctx: Context) -> tuple:
    try:
        result = converter.coerce(value, param=param, ctx=ctx)
    except BadParameter as error:
        return ("error", error.format_message())
    return ("value", type(result), result)


def _parameters():
    for name in ["", *_COMMANDS]:
        command = _GROUP if not name else _GROUP.commands[name]
        ctx = Context(command, info_name=name or "brdfkit")
        params = command.get_params(ctx)
        plain_values(params)
        for param in params:
            if hasattr(param, "type_descriptor"):
                yield name, command, ctx, param


def _same(a: tuple, b: tuple) -> bool:
    """Equal outcomes (NaN equal to NaN)."""
    return a == b or (a[0] == b[0] == "value" and a[1] is b[1] is float and a[2] != a[2] != b[2])


def test_every_parameter_converts_as_typer_does(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    inputs = _inputs(tmp_path)
    seen = {}
    for name, _, ctx, param in _parameters():
        descriptor = param.type_descriptor
        kind = (repr(descriptor.annotation), descriptor.parameter_info.min,
                descriptor.parameter_info.max, param.multiple, param.nargs)  # fmt: skip
        if kind in seen:
            continue
        seen[kind] = name
        typers = build_runtime_param(descriptor)
        for value in inputs:
            ours = _outcome(param.get_runtime_param(), value, param, ctx)
            theirs = _outcome(typers, value, param, ctx)
            assert _same(ours, theirs), (name, param.name, value, ours, theirs)
    assert len(seen) >= 10  # str, Path, int and float with and without bounds, lists, bool


def test_every_default_converts_without_typers_converter():
    built = []
    for name, _, ctx, param in _parameters():
        converter = _PlainConverter(param, lambda n=name, p=param: built.append((n, p.name)))
        if param.default is not None and not callable(param.default):
            converter.coerce(param.default, param=param, ctx=ctx)
    enums = [(name, p) for name, p in built if name == "solid-angle" and p == "shape"]
    assert built == enums  # the one enum goes to typer


def test_a_render_command_imports_no_pydantic(tmp_path):
    code = (
        "import sys; from brdfkit.cli import app; "
        "from typer.testing import CliRunner; "
        "r = CliRunner().invoke(app, ['render', '-r', '16', '-s', '1', '-b', 'lambertian', "
        "'-l', 'directional:0,0,1', '-o', 'out.png', '--exposure', '-0.5']); "
        "print(r.exit_code, 'pydantic' in sys.modules)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )
    assert done.stdout.split() == ["0", "False"], done.stdout + done.stderr
    assert (tmp_path / "out.png").stat().st_size > 0


def test_another_typer_release_is_left_as_it_is(monkeypatch):
    monkeypatch.setattr(typer, "__version__", "0.30.0")
    command = _GROUP.commands["render"]
    params = [p for p in command.get_params(Context(command, info_name="render"))
              if hasattr(p, "type_descriptor")]  # fmt: skip
    for param in params:  # as typer leaves a parameter before its first conversion
        monkeypatch.setattr(param, "_runtime_param", None)
    plain_values(params)
    assert not engaged()
    assert params and all(p._runtime_param is None for p in params)
    monkeypatch.setattr(typer, "__version__", "0.29.2")
    plain_values(params)
    assert all(isinstance(p._runtime_param, _PlainConverter) for p in params)
