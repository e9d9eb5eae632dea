"""``brdfkit.load``: one loader for specs, measured files, fit.json and BRDF Explorer files."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import brdfkit
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.errors import FormatError, ParameterError, SpecError
from brdfkit.interop.brdf_explorer import ExplorerBRDF
from brdfkit.interop.load import load

CONSTRUCTS = Path(__file__).parent / "data" / "constructs.brdf"
W = np.array([[0.0, 0.6, 0.8], [0.6, 0.0, 0.8]])


def test_brdfkit_load_is_this_loader_and_import_brdfkit_stays_cheap():
    assert brdfkit.load is load
    assert "load" in brdfkit.__all__
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        brdfkit.nothing  # noqa: B018


def test_import_brdfkit_does_not_import_the_loader():
    import subprocess

    code = "import sys, brdfkit; print('brdfkit.interop' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_a_spec_with_and_without_overrides():
    assert load("lambertian(albedo=0.5)").rho == 0.5
    ggx = load("ggx(alpha=0.2)", alpha=0.4)
    assert ggx.alpha == 0.4
    assert load("lambertian", albedo=0.3).rho == 0.3  # a spec alias
    with pytest.raises(SpecError, match="ggx has no parameter 'n'; its parameters"):
        load("ggx", n=3)
    with pytest.raises(SpecError, match=r"parameters \(alpha\) set a single model"):
        load("lambertian + ggx", alpha=0.1)
    with pytest.raises(ParameterError, match="alpha"):
        load("ggx", alpha=-1.0)


def test_a_brdf_passes_through():
    model = Lambertian(rho=0.2)
    assert load(model) is model
    assert load(model, rho=0.4).rho == 0.4


def test_a_brdf_explorer_file_with_overrides(tmp_path):
    brdf = load(CONSTRUCTS, which=0.0, tint=[0.3, 0.3, 0.3])
    assert isinstance(brdf, ExplorerBRDF)
    np.testing.assert_allclose(brdf.eval(W, W), np.full((2, 3), 0.3 / np.pi))
    assert isinstance(load(str(CONSTRUCTS)), ExplorerBRDF)  # a string path is a file too


def test_a_fit_json_gives_its_fitted_spec(tmp_path):
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"spec": "lambertian(rho=0.25) + ggx(alpha=0.3)", "errors": {}}))
    model = load(path)
    assert model.to_spec() == load("lambertian(rho=0.25) + ggx(alpha=0.3)").to_spec()
    single = tmp_path / "single.json"
    single.write_text(json.dumps({"spec": "ggx(alpha=0.3)"}))
    assert load(single, alpha=0.5).alpha == 0.5
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"model": "ggx"}))
    with pytest.raises(FormatError, match=r'bad\.json: has no "spec" string'):
        load(bad)
    bad.write_text("{not json")
    with pytest.raises(FormatError, match=r"bad\.json: is not JSON"):
        load(bad)


def test_a_measured_file_takes_no_parameters(shared_data):
    path = shared_data / "measured" / "rgl" / "acrylic_felt_green_rgb.bsdf"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    brdf = load(path)
    assert np.all(np.isfinite(brdf.eval(W, W)))
    with pytest.raises(ParameterError, match="is measured data and takes no parameters; got rho"):
        load(path, rho=0.5)


def test_a_brdf_file_that_is_not_a_shader_goes_to_the_cornell_reader(tmp_path):
    path = tmp_path / "sample.brdf"
    path.write_text("31\n400 410\n")
    with pytest.raises(FormatError) as caught:
        load(path)
    assert "GLSL" not in str(caught.value) and "BRDF Explorer" not in str(caught.value)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"BRDF file not found: .*nothing\.brdf"):
        load(tmp_path / "nothing.brdf")
