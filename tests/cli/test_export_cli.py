"""``brdfkit export`` and ``brdfkit fit --export``: files for other tools, refusals in one line."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest
from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.measured import read_rgl

runner = CliRunner()


def _one_line(result) -> str:
    return " ".join(result.output.split())


def test_a_spec_exported_to_mitsuba(tmp_path):
    out = tmp_path / "plastic.xml"
    spec = "lambertian(albedo=0.3) + ggx(alpha=0.2, masking='smith_separable')"
    result = runner.invoke(app, ["export", spec, "--to", "mitsuba", "-o", str(out)])
    assert result.exit_code == 0, result.output
    root = ET.parse(out).getroot()
    assert root.tag == "bsdf" and root.get("type") == "blendbsdf"
    assert [child.get("type") for child in root.iter("bsdf")][1:] == ["diffuse", "roughconductor"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plastic.xml"]


def test_inexact_and_missing_counterparts_are_refused_in_one_line(tmp_path):
    out = tmp_path / "m.xml"
    refused = runner.invoke(app, ["export", "ggx(alpha=0.2)", "--to", "mitsuba", "-o", str(out)])
    assert refused.exit_code == 2 and "masking='smith_correlated'" in _one_line(refused)
    approximated = runner.invoke(
        app, ["export", "ggx(alpha=0.2)", "--to", "mitsuba", "-o", str(out), "--approximate"]
    )
    assert approximated.exit_code == 0 and "note: GGXConductor masking" in approximated.output
    phong = runner.invoke(
        app, ["export", "phong", "--to", "mitsuba", "-o", str(tmp_path / "p.xml")]
    )
    assert phong.exit_code == 2 and "Phong has no Mitsuba 3 counterpart" in _one_line(phong)
    assert "Traceback" not in phong.output and not (tmp_path / "p.xml").exists()


def test_bad_format_and_suffix(tmp_path):
    unknown = runner.invoke(app, ["export", "lambertian", "--to", "obj", "-o", str(tmp_path / "a")])
    assert unknown.exit_code == 2 and "format must be one of mitsuba, rgl" in _one_line(unknown)
    suffix = runner.invoke(
        app, ["export", "lambertian", "--to", "rgl", "-o", str(tmp_path / "a.xml")]
    )
    assert suffix.exit_code == 2 and "must end in .bsdf; got 'a.xml'" in _one_line(suffix)
    assert not any(tmp_path.iterdir())


def test_a_spec_exported_to_rgl(tmp_path):
    out = tmp_path / "white.bsdf"
    result = runner.invoke(app, ["export", "lambertian(albedo=0.5)", "--to", "rgl", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert read_rgl(out).channels == 3 and "lambertian" in read_rgl(out).description


def test_a_measured_file_is_read_and_never_written_over(shared_data, tmp_path):
    felt = shared_data / "measured" / "rgl" / "acrylic_felt_green_rgb.bsdf"
    if not felt.is_file():
        pytest.skip(f"{felt} is absent")
    refused = runner.invoke(
        app, ["export", str(felt), "--to", "mitsuba", "-o", str(tmp_path / "f.xml")]
    )
    assert refused.exit_code == 2 and "RGLBRDF has no Mitsuba 3 counterpart" in _one_line(refused)
    copy = tmp_path / "copy.bsdf"
    copy.write_bytes(felt.read_bytes())
    same = runner.invoke(app, ["export", str(copy), "--to", "rgl", "-o", str(copy)])
    assert same.exit_code == 2 and "is an input" in _one_line(same)
    assert copy.read_bytes() == felt.read_bytes()


def test_fit_export_needs_an_output_folder(shared_data, tmp_path):
    path = shared_data / "measured" / "cornell" / "garnet_red.brdf"
    result = runner.invoke(app, ["fit", str(path), "--export", "mitsuba"])
    assert result.exit_code == 2 and "give -o FOLDER" in _one_line(result)
    wrong = runner.invoke(app, ["fit", str(path), "--export", "obj", "-o", str(tmp_path / "f")])
    assert wrong.exit_code == 2 and "format must be one of" in _one_line(wrong)


@pytest.mark.slow
def test_fit_exports_the_fitted_model(shared_data, tmp_path):
    path = shared_data / "measured" / "cornell" / "garnet_red.brdf"
    out = tmp_path / "garnet"
    args = ["fit", str(path), "--model", "lambertian", "--starts", "1", "-r", "16"]
    result = runner.invoke(app, [*args, "-o", str(out), "--export", "mitsuba"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "fit.json", "material.xml", "spheres.png"
    ]  # fmt: skip
    fitted = parse(json.loads((out / "fit.json").read_text())["spec"])
    reflectance = ET.parse(out / "material.xml").getroot().find("rgb")
    assert reflectance.get("name") == "reflectance"
    exported = [float(v) for v in reflectance.get("value").split(",")]
    assert exported == pytest.approx(list(fitted.rho), rel=1e-12)
