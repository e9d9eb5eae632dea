"""Model selection by held-out error: it picks the candidate that generalises (an analytic
model for analytic data, the bivariate table for a colour that turns with θd); the bivariate
path of ``brdfkit fit``; bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.errors import ParameterError
from brdfkit.fit import fit_any, select_model
from brdfkit.fit.analytic import fit_data
from brdfkit.fit.select import BIVARIATE
from brdfkit.measured.bivariate_brdf import Bivariate


def test_selects_the_analytic_model_for_analytic_data():
    truth = parse("lambertian(albedo=[0.5, 0.3, 0.2]) + ggx(alpha=0.25)")
    data = fit_data(truth, samples=3000, seed=1)
    selection = select_model(data, ("lambertian + ggx", "lambertian + ward"), starts=1)
    assert selection.chosen == "lambertian + ggx"
    assert set(selection.held_out) == {"lambertian + ggx", "lambertian + ward"}
    assert selection.result.errors["relative_l2"] < 0.02


def test_selects_the_bivariate_table_for_a_colour_turning_with_theta_d():
    # blue near the mirror configuration, red towards grazing θd: no single-colour lobe
    table = np.zeros((8, 6, 3))
    table[..., 2] = np.linspace(1.0, 0.05, 6)[None, :] * np.linspace(3, 0.3, 8)[:, None]
    table[..., 0] = np.linspace(0.05, 1.0, 6)[None, :] * np.linspace(3, 0.3, 8)[:, None]
    table[..., 1] = 0.05
    data = fit_data(Bivariate(table), samples=4000, seed=2)
    selection = select_model(data, ("lambertian + ggx", BIVARIATE), starts=1)
    assert selection.chosen == BIVARIATE
    assert selection.held_out[BIVARIATE] < 0.5 * selection.held_out["lambertian + ggx"]


def test_bad_selection_input():
    data = fit_data(parse("lambertian"), samples=100)
    with pytest.raises(ParameterError, match="candidates"):
        select_model(data, ())
    with pytest.raises(ParameterError, match="objective"):
        select_model(data, (BIVARIATE,), objective="nope")


def test_fit_any_bivariate_result_is_serialisable():
    result = fit_any(fit_data(parse("lambertian + ggx"), samples=2000), BIVARIATE)
    record = json.loads(json.dumps(result.to_dict()))
    assert record["spec"].startswith("bivariate") and record["params"] == {}


@pytest.mark.slow
@pytest.mark.data
def test_cli_fits_the_bivariate_table_and_refuses_fix_with_it(shared_data, tmp_path):
    path = shared_data / "measured" / "cornell" / "krylon_blue.brdf"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    runner = CliRunner()
    result = runner.invoke(app, ["fit", str(path), "--model", "bivariate", "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["spec"].startswith("bivariate")
    result = runner.invoke(app, ["fit", str(path), "--model", "auto", "--fix", "alpha"])
    assert result.exit_code == 2 and "--fix" in result.stderr
