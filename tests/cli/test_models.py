"""``brdfkit models``: every registered model with its parameters, defaults and claims."""

from __future__ import annotations

import dataclasses
import json
import math

from typer.testing import CliRunner

from brdfkit.brdf import MODELS
from brdfkit.brdf.spec import parse
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


def _blocks(text: str) -> list[list[str]]:
    """The models' blocks of the text output: a line at the margin starts a model."""
    blocks: list[list[str]] = []
    names = tuple(f"{name}  " for name in MODELS)
    for line in text.splitlines():
        if line.startswith(names):
            blocks.append([line])
        elif blocks:
            blocks[-1].append(line)
    return blocks


def test_each_model_is_a_short_block_at_80_columns_with_no_word_split():
    narrow = runner.invoke(app, ["models"], env={"COLUMNS": "80"})
    wide = runner.invoke(app, ["models"], env={"COLUMNS": "1000"})
    assert narrow.exit_code == 0 and wide.exit_code == 0, narrow.output
    assert max(len(line) for line in narrow.stdout.splitlines()) <= 80
    blocks, wide_blocks = _blocks(narrow.stdout), _blocks(wide.stdout)
    assert [b[0].split()[0] for b in blocks] == sorted(MODELS)
    for block, one_line in zip(blocks, wide_blocks, strict=True):
        # Parameters fill their lines: a block is at most one line longer than the fewest
        # 78-column lines its parameter text could take (no parameter alone on a line).
        parameters = " ".join(line.strip() for line in one_line[1:])
        assert len(block) <= 2 + math.ceil(len(parameters) / 78), block
        # Wrapping only moved whole words (and whole parameters) to the next line.
        assert " ".join(block).split() == " ".join(one_line).split()
        assert all(line.startswith("  ") for line in block[1:])
    ggx = next(b for b in blocks if b[0].startswith("ggx "))
    assert "reciprocal, energy-conserving, isotropic" in ggx[0]
    assert "alpha=0.1 ∈ [0.0001, 10]" in " ".join(ggx)
    phong = next(b for b in blocks if b[0].startswith("phong "))
    assert "not reciprocal" in phong[0]


def test_domains_are_the_ones_the_validation_declares():
    from brdfkit.brdf.base import ALBEDO, EXPONENT, ROUGHNESS
    from brdfkit.brdf.microfacet import EXTINCTION, IOR
    from brdfkit.brdf.phong import PHONG_KD
    from brdfkit.brdf.ward import WARD_ALPHA

    result = runner.invoke(app, ["models", "--json"])
    records = {r["name"]: r for r in json.loads(result.stdout)}

    def domain(model: str, name: str):
        record = dict(records[model]["domains"][name])
        assert record.pop("interval").startswith("[")
        return type(ROUGHNESS)(**record)

    assert domain("ggx", "alpha") == domain("ggx", "alpha_u") == ROUGHNESS
    assert domain("ggx", "eta") == IOR and domain("ggx", "k") == EXTINCTION
    assert domain("lambertian", "rho") == ALBEDO and domain("phong", "n") == EXPONENT
    assert domain("phong", "kd") == PHONG_KD and domain("ward", "alpha_y") == WARD_ALPHA
    for name, record in records.items():
        numeric = [
            k for k, v in record["parameters"].items() if v is not None and v[:1] in "[-0123456789"
        ]
        assert set(numeric) <= set(record["domains"]), name  # every number has its domain
        for key in record["domains"]:
            assert key in record["parameters"]
