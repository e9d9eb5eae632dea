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
