"""Every command's ``--help`` at 80 columns: reflowed paragraphs, metavars that say what to
type, and ``--json`` on each command that prints a table."""

from __future__ import annotations

import itertools

import pytest
from rich.cells import cell_len
from typer.testing import CliRunner

from brdfkit.cli import app

runner = CliRunner()
COMMANDS = sorted(info.name for info in app.registered_commands)
TABLES = ("check", "fit", "fresnel", "models", "ps", "solid-angle")
"""The commands that print a table, and so have --json."""


def _help(command: str) -> str:
    result = runner.invoke(app, [command, "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    return result.stdout


def _description(text: str) -> list[str]:
    """The lines of the help's description: after the usage line, before the first panel."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if "Usage:" in line) + 1
    end = next((i for i, line in enumerate(lines) if line.startswith("╭")), len(lines))
    return [line.strip() for line in lines[start:end]]


@pytest.mark.parametrize("command", COMMANDS)
def test_help_fits_80_columns_with_paragraphs_wrapped_not_hard_broken(command):
    text = _help(command)
    assert max(cell_len(line) for line in text.splitlines()) <= 80
    description = _description(text)
    assert any(description)
    for line, following in itertools.pairwise(description):
        if line and following:  # within a paragraph a line breaks only where the next word
            assert cell_len(line) + 1 + cell_len(following.split()[0]) > 78, (line, following)


@pytest.mark.parametrize("command", COMMANDS)
def test_every_option_that_takes_a_value_names_what_to_type(command):
    options = [line for line in _help(command).splitlines() if line.lstrip("│ *").startswith("-")]
    generic = ("<str>", "<path>", "<float>", "<int", "<list", "<text>")
    assert [line for line in options if any(g in line for g in generic)] == []


@pytest.mark.parametrize("command", TABLES)
def test_commands_printing_a_table_have_json(command):
    assert "--json" in _help(command)


def test_metavars_the_issue_names():
    assert "SPEC" in _help("render") and "FOLDER" in _help("ps") and "FILE" in _help("hdr")
    assert "T1,T2,..." in _help("hdr") and "X,Y,Z" in _help("sfs")
