"""``brdfkit check``: the physics report of a model spec, its exit codes and JSON output."""

from __future__ import annotations

import json
from dataclasses import dataclass

import pytest
from typer.testing import CliRunner

from brdfkit.brdf import MODELS
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.cli import app
from brdfkit.cli._app import console

runner = CliRunner()


@dataclass(frozen=True, eq=False)
class Skewed(Lambertian):
    """ρ/π · (1 + wi.x/2): claims reciprocity and isotropy (inherited) but has neither."""

    spec_name = "skewed_toy"

    def eval(self, wi, wo):
        return super().eval(wi, wo) * (1 + 0.5 * wi[..., :1])


@pytest.fixture
def wide_console(monkeypatch):
    """A console wide enough that table cells do not wrap."""
    monkeypatch.setattr(console, "width", 240)


def _json(result) -> dict:
    assert result.exception is None or isinstance(result.exception, SystemExit), result.output
    return json.loads(result.stdout)


def test_lambertian_is_consistent(wide_console):
    result = runner.invoke(app, ["check", "lambertian(albedo=[0.8, 0.4, 0.2])"])
    assert result.exit_code == 0, result.output
    for verdict in (
        "reciprocal (as claimed)",
        "energy-conserving (as claimed)",
        "isotropic (as claimed)",
        "consistently sampled (as claimed)",
    ):
        assert verdict in result.stdout
    assert "every measurement agrees" in result.stdout


def test_original_phong_is_not_reciprocal_as_it_claims(wide_console):
    if "phong" not in MODELS:
        pytest.skip("the original Phong model is not registered yet")
    result = runner.invoke(app, ["check", "phong(n=20)"])
    assert result.exit_code == 0, result.output
    assert "not reciprocal (as it claims)" in result.stdout
    data = _json(runner.invoke(app, ["check", "phong(n=20)", "--json"]))
    reciprocity = next(c for c in data["checks"] if c["name"] == "reciprocity")
    assert reciprocity["passed"] is False and reciprocity["claimed"] is False
    assert reciprocity["value"] > 1e-2  # grossly non-reciprocal, not a rounding effect
    assert data["consistent"] is True


def test_json_report_is_strict_json_with_every_check():
    result = runner.invoke(app, ["check", "0.5 * lambertian + lambertian(albedo=0.2)", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout, parse_constant=pytest.fail)
    assert data["model"] == (0.5 * Lambertian() + Lambertian(0.2)).to_spec()
    assert [c["name"] for c in data["checks"]] == [
        "non-negativity",
        "reciprocity",
        "energy",
        "isotropy",
        "sampling",
    ]
    energy = next(c for c in data["checks"] if c["name"] == "energy")
    assert energy["value"] == pytest.approx(0.45, abs=1e-12)  # 0.5·0.5 + 0.2, exactly known


def test_a_contradicted_claim_exits_with_1(monkeypatch, wide_console):
    monkeypatch.setitem(MODELS, "skewed_toy", Skewed)
    result = runner.invoke(app, ["check", "skewed_toy"])
    assert result.exit_code == 1, result.output
    assert "not reciprocal: CONTRADICTS its claim" in result.stdout
    assert "measurements contradict the model's claims" in result.stdout
    data = _json(runner.invoke(app, ["check", "skewed_toy", "--json"]))
    assert data["consistent"] is False
    assert {c["name"] for c in data["checks"] if c["contradicts_claim"]} >= {
        "reciprocity",
        "isotropy",
    }


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("lambertain", "unknown model 'lambertain'"),
        ("lambertian(sigma=1)", "has no parameter 'sigma'"),
        ("lambertian(", "not a valid model expression"),
        ("lambertian(albedo=3)", "rho must be in [0.0, 1.0]"),
    ],
)
def test_bad_specs_exit_with_2_and_say_why(spec, message, wide_console):
    result = runner.invoke(app, ["check", spec])
    assert result.exit_code == 2
    assert "error:" in result.stderr and message in result.stderr
    assert "error" not in result.stdout
