"""``brdfkit fresnel``: the table and its JSON agree with brdfkit.fresnel; bad input exits 2."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.fresnel import IOR, conductor, f0_from_conductor, fresnel_dielectric

runner = CliRunner()


def _json(*args: str) -> dict:
    result = runner.invoke(app, ["fresnel", *args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


def test_table_for_glass():
    result = runner.invoke(app, ["fresnel", "--ior", "1.5"])
    assert result.exit_code == 0, result.output
    for header in ("Rs", "Rp", "R", "T = 1 − R"):
        assert header in result.output
    rows = [line for line in result.output.splitlines() if line.startswith("│")]
    assert len(rows) == 8  # the default angles 0, 15, 30, 45, 60, 75, 85, 89
    cells = [cell.strip() for cell in rows[0].split("│")[1:-1]]
    assert cells == ["0", "0.0400", "0.0400", "0.0400", "0.9600"]


def test_table_for_gold_shows_rgb():
    result = runner.invoke(app, ["fresnel", "--material", "Au"])
    assert result.exit_code == 0, result.output
    f0 = f0_from_conductor(*map(np.array, conductor("Au")))
    assert " ".join(f"{v:.4f}" for v in f0) in result.output
    assert "…" not in result.output  # nothing cut off at 80 columns


def test_json_matches_the_library():
    record = _json("--ior", "1.5", "--angles", "0,30,60,89")
    angles = [row["angle_deg"] for row in record["rows"]]
    assert angles == [0, 30, 60, 89]
    cos = np.cos(np.radians(angles))[:, None]
    r_s, r_p = fresnel_dielectric(cos, 1.5, polarized=True)
    np.testing.assert_allclose([row["Rs"] for row in record["rows"]], r_s, rtol=1e-12)
    np.testing.assert_allclose([row["Rp"] for row in record["rows"]], r_p, rtol=1e-12)
    np.testing.assert_allclose([row["R"] for row in record["rows"]], (r_s + r_p) / 2, rtol=1e-12)


def test_conductor_json_normal_incidence_and_grazing():
    record = _json("--material", "cu", "--angles", "0,90")
    eta, k = conductor("Cu")
    np.testing.assert_allclose(
        record["rows"][0]["R"], f0_from_conductor(np.array(eta), k), rtol=1e-12
    )
    np.testing.assert_allclose(record["rows"][1]["R"], 1.0, atol=1e-12)
    custom = _json("--ior", "0.2", "--k", "3", "--angles", "0")
    assert custom["rows"][0]["R"] == pytest.approx([(0.8**2 + 9) / (1.2**2 + 9)], rel=1e-12)


def test_inside_shows_total_internal_reflection():
    record = _json("--material", "diamond", "--inside", "--angles", "10,30,60")
    theta_c = math.degrees(math.asin(1 / IOR["diamond"]))
    assert 10 < theta_c < 30
    assert record["rows"][0]["R"][0] < 1
    assert record["rows"][1]["R"] == [1.0] and record["rows"][2]["R"] == [1.0]
    table = runner.invoke(app, ["fresnel", "--material", "diamond", "--inside"]).output
    assert f"critical angle {theta_c:.2f}°" in table


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--material", "unobtainium"], "Au"),
        (["--material", "Au", "--ior", "1.5"], "exactly one"),
        ([], "exactly one"),
        (["--ior", "-1"], "eta must be in (0.0, inf]; got -1"),
        (["--ior", "0.2", "--k", "-3"], "k must be in [0.0, inf]; got -3"),
        (["--material", "Au", "--k", "2"], "--k"),
        (["--material", "Au", "--inside"], "dielectrics only"),
        (["--ior", "1.5", "--angles", "0,95"], "[0, 90]"),
        (["--ior", "1.5", "--angles", "a,b"], "comma-separated"),
    ],
)
def test_bad_input_exits_2_with_a_message(args, message):
    result = runner.invoke(app, ["fresnel", *args])
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())
