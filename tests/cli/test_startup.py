"""``brdfkit --help`` and every ``brdfkit CMD --help`` import no NumPy: the command line starts
fast because each command imports what it computes with only when it runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

_HELP_EVERYWHERE = """
import sys
from typer.testing import CliRunner
from brdfkit.cli import app

runner = CliRunner()
names = [command.name for command in app.registered_commands]
for words in ([], *([name] for name in names)):
    result = runner.invoke(app, [*words, "--help"])
    assert result.exit_code == 0, (words, result.output)
heavy = sorted(
    name for name in sys.modules if name.split(".")[0] in ("numpy", "scipy", "matplotlib")
)
print(len(names), heavy[:5])
"""


def test_help_of_every_command_imports_no_numpy():
    done = subprocess.run(
        [sys.executable, "-c", _HELP_EVERYWHERE],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )
    assert done.returncode == 0, done.stderr
    commands, heavy = done.stdout.split(" ", 1)
    assert int(commands) >= 19 and heavy.strip() == "[]", done.stdout


def test_atlas_defaults_are_the_library_defaults():
    import inspect

    from brdfkit.cli import atlas as atlas_cli
    from brdfkit.report import atlas

    assert atlas_cli.ENV_NOISE == atlas.ENV_NOISE
    assert atlas_cli.ENV_MAX_SAMPLES == atlas.ENV_MAX_SAMPLES
    defaults = inspect.signature(atlas_cli.atlas_command).parameters
    assert defaults["max_samples"].default == atlas.ENV_MAX_SAMPLES


_COMMAND_MODULES = """
import sys
sys.argv = ["brdfkit", *sys.argv[1:]]
from brdfkit.cli import main
try:
    main()
except SystemExit:
    pass
names = sorted(name for name in sys.modules if name.startswith("brdfkit.cli."))
print()
print(" ".join(name for name in names if not name.rpartition(".")[2].startswith("_")))
"""


def _command_modules(*words: str) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-c", _COMMAND_MODULES, *words],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()[-1].split()  # after the help text


def test_the_console_script_imports_the_module_of_its_command_alone():
    assert _command_modules("solid-angle", "--help") == ["brdfkit.cli.solid_angle"]
    everything = _command_modules("--help")  # the listing: every command's module
    assert "brdfkit.cli.render" in everything and len(everything) >= 19


def test_the_start_up_pauses_the_collector_and_freezes_only_in_the_commands_own_process(
    monkeypatch,
):
    import gc

    from brdfkit.cli import _entry

    frozen = gc.get_freeze_count()
    assert gc.isenabled()
    with _entry.start_up():
        assert not gc.isenabled()
    assert gc.isenabled() and gc.get_freeze_count() == frozen  # a test's process: no freeze
    monkeypatch.setattr(_entry, "_OWN_PROCESS", [True])
    try:
        with _entry.start_up():
            kept = [object()]
        assert gc.isenabled() and gc.get_freeze_count() > frozen
    finally:
        gc.unfreeze()
    assert kept


def test_progress_off_a_terminal_takes_the_bars_calls_and_shows_nothing(capsys):
    from brdfkit.cli._app import progress

    with progress() as bar:  # pytest's stderr is no terminal
        task = bar.add_task("rendering", total=4)
        bar.update(task, completed=2)
        bar.refresh()
    assert type(bar).__module__ == "brdfkit.cli._app"
    assert capsys.readouterr().err == ""


def test_a_render_starts_openblas_with_one_thread_unless_numpy_is_there(monkeypatch):
    from brdfkit.cli import render

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    render._blas_on_one_thread()  # NumPy imported already: nothing changes
    assert "OPENBLAS_NUM_THREADS" not in os.environ
    monkeypatch.delitem(sys.modules, "numpy")
    render._blas_on_one_thread()
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "4")  # the user's choice stands
    render._blas_on_one_thread()
    assert os.environ["OPENBLAS_NUM_THREADS"] == "4"
