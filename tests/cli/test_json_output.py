"""``--json`` wherever a command prints a table: standard output holds the JSON alone."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit import radiometry
from brdfkit.cli import app
from brdfkit.vision import datasets
from brdfkit.vision.photometric_stereo import sphere_normals

runner = CliRunner()


def _json(args: list[str]) -> dict:
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)  # the whole of stdout is one JSON document


def test_solid_angle_json_has_every_row_of_the_table():
    record = _json(["solid-angle", "disk", "--radius", "2", "--distance", "1", "--json"])
    exact = float(radiometry.solid_angle_disk_on_axis(2.0, 1.0))
    assert record["shape"] == "disk" and record["observer"] == [0.0, 0.0, 1.0]
    assert len(record["rows"]) == 3
    for row in record["rows"]:
        assert row["omega_sr"] == pytest.approx(exact, rel=1e-9)
        assert row["fraction_of_hemisphere"] == pytest.approx(exact / (2 * math.pi), rel=1e-9)
    assert record["abs_difference_sr"] < 1e-9
    cap = _json(["solid-angle", "cap", "--half-angle", "60", "--json"])
    assert cap["rows"][0]["omega_sr"] == pytest.approx(math.pi)  # 2π(1 − cos 60°)


def test_ps_json_has_the_measures_and_the_files_written(tmp_path):
    normals, mask = sphere_normals((24, 24), (11.5, 11.5), 9.0)
    lights = datasets.diligent_like_lights(3, 3, np.radians(25))
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    datasets.save_diligent(
        datasets.render_synthetic(normals, lit, lights, albedo=0.6), tmp_path / "ballPNG"
    )
    out = tmp_path / "out"
    record = _json(["ps", tmp_path / "ballPNG", "-m", "least_squares", "-o", out, "--json"])
    assert record["method"] == "least_squares" and record["lights"] == 9
    assert record["pixels"] == int(lit.sum())
    assert record["angular_error_deg"]["mean"] < 1.0
    assert 0 <= record["depth_relative_rmse"] < 0.1
    assert sorted(record["files"]) == sorted(p.name for p in out.iterdir() if p.name[0] != ".")


def test_fit_json_has_the_parameters_errors_and_sphere_differences(shared_data, tmp_path):
    path = shared_data / "measured" / "cornell" / "garnet_red.brdf"
    args = ["fit", path, "--model", "lambertian", "--starts", "1", "--json"]
    record = _json(args)
    assert record["file"] == str(path) and record["spec"].startswith("lambertian(")
    assert set(record["errors"]) >= {"rmse", "cosine_rmse"} and "output" not in record
    out = tmp_path / "fit"
    record = _json([*args, "-o", out, "-r", "16"])
    assert record["output"] == str(out)
    assert (
        record["delta_e_directional"]
        == json.loads((out / "fit.json").read_text())["delta_e_directional"]
    )
