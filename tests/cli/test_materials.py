"""``brdfkit materials``: lists the presets (text and JSON), filters by fit and model, refuses
an unknown fit with one line and status 2."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.materials import catalogue

runner = CliRunner()


def test_json_lists_every_preset_with_a_spec_that_parses():
    result = runner.invoke(app, ["materials", "--json"])
    assert result.exit_code == 0, result.output
    records = json.loads(result.stdout)
    assert records == catalogue()
    assert len(records) == 86 * 6 + 100 * 7
    assert parse(records[0]["spec"]).eval is not None


def test_filters_by_fit_and_model():
    result = runner.invoke(app, ["materials", "--json", "--model", "ward"])
    assert {r["fit"] for r in json.loads(result.stdout)} == {"ngan_ward", "ngan_wardduer"}
    result = runner.invoke(app, ["materials", "--fit", "low_lowsmooth_E2"])
    assert result.exit_code == 0
    assert "low_lowsmooth_E2" in result.stdout and "alum-bronze" in result.stdout
    assert "ngan_ward" not in result.stdout


def test_unknown_fit_is_one_line_and_status_2():
    result = runner.invoke(app, ["materials", "--fit", "ngan_he"])
    assert result.exit_code == 2
    assert "--fit" in result.stderr and "ngan_he" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
