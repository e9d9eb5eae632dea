"""``brdfkit models``: every registered model with its parameters, defaults and claims."""

from __future__ import annotations

import dataclasses
import json

from typer.testing import CliRunner

from brdfkit.brdf import MODELS
from brdfkit.brdf._spec import parse
from brdfkit.cli import app

runner = CliRunner()


def test_json_lists_every_registered_model_with_its_defaults_and_claims():
    result = runner.invoke(app, ["models", "--json"])
    assert result.exit_code == 0, result.output
    records = {r["name"]: r for r in json.loads(result.stdout)}
    assert set(records) == set(MODELS)
    for name, cls in MODELS.items():
        record = records[name]
        fields = [f.name for f in dataclasses.fields(cls) if f.init]
        assert list(record["parameters"]) == fields
        assert record["claims"]["has_delta"] == cls.has_delta
        # The defaults are spec text: writing them back builds the default model.
        given = {k: v for k, v in record["parameters"].items() if v is not None}
        spec = f"{name}({', '.join(f'{k}={v}' for k, v in given.items())})"
        assert parse(spec).to_spec() == cls().to_spec()
    lambertian = records["lambertian"]
    assert lambertian["parameters"]["rho"] == "0.5"
    assert lambertian["claims"]["reciprocal"] is True
    assert "math" not in lambertian["summary"]  # reST roles are stripped
    if "phong" in records:
        assert records["phong"]["claims"]["reciprocal"] is False


def test_table_names_every_model():
    result = runner.invoke(app, ["models"])
    assert result.exit_code == 0, result.output
    for name in MODELS:
        assert name in result.stdout
