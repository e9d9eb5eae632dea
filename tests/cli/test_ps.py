"""``brdfkit ps``: outputs match the library, errors are reported, bad input writes nothing."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.io import read_image
from brdfkit.vision import datasets
from brdfkit.vision.bilateral_integration import PIECES, bilateral_integration
from brdfkit.vision.bivariate_stereo import shared_bivariate
from brdfkit.vision.photometric_stereo import (
    calibrate_lights_chrome_sphere,
    least_squares,
    sphere_normals,
)

runner = CliRunner()


def _invoke(*args):
    return runner.invoke(app, ["ps", *(str(a) for a in args)])


@pytest.fixture
def ball(tmp_path):
    """A Lambertian sphere in the DiLiGenT layout, fully lit by 12 lights."""
    normals, mask = sphere_normals((30, 36), (17.5, 14.5), 12.0)
    lights = datasets.diligent_like_lights(4, 3, np.radians(30))
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    data = datasets.render_synthetic(normals, lit, lights, albedo=[0.7, 0.5, 0.3])
    datasets.save_diligent(data, tmp_path / "ballPNG")
    return tmp_path / "ballPNG"


def test_outputs_match_the_library(ball, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    out = tmp_path / "out"
    result = _invoke(ball, "--method", "least_squares", "-o", out)
    assert result.exit_code == 0, result.output
    assert "mean angular error" in result.output
    data = datasets.load_diligent(ball)
    expected = least_squares(data.images, data.light_directions, data.mask)
    np.testing.assert_allclose(np.load(out / "normals.npy"), expected.normals)
    np.testing.assert_allclose(np.load(out / "albedo.npy"), expected.albedo)
    decoded = datasets.read_normal_map(out / "normals.png")
    np.testing.assert_allclose(decoded[data.mask], expected.normals[data.mask], atol=2e-5)
    depth = np.load(out / "depth.npy")
    exr = read_image(out / "depth.exr")[..., 0]
    np.testing.assert_allclose(exr, depth.astype(np.float32), equal_nan=True)
    expected_depth = bilateral_integration(expected.normals, data.mask, pieces=PIECES).depth
    np.testing.assert_allclose(depth, expected_depth)
    error = np.load(out / "angular_error.npy")
    assert np.nanmax(error) < 0.05  # 16-bit Lambertian images: least squares is exact
    mesh = trimesh.load(out / "mesh.ply")
    assert len(mesh.vertices) == data.mask.sum()
    # Faces wind counter-clockwise seen from the camera: normals point towards +z.
    assert np.all(mesh.face_normals[:, 2] > 0)


def test_the_default_method_is_shared_bivariate(ball, tmp_path):
    out = tmp_path / "out"
    result = _invoke(ball, "-o", out, "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["method"] == "shared_bivariate"
    data = datasets.load_diligent(ball)
    expected = shared_bivariate(data.images, data.light_directions, data.mask)
    np.testing.assert_allclose(np.load(out / "normals.npy"), expected.normals)


def test_perspective_by_default_with_a_camera(ball, tmp_path):
    camera = np.array([[300.0, 0.0, 18.0], [0.0, 300.0, 15.0], [0.0, 0.0, 1.0]])
    np.savetxt(tmp_path / "K.txt", camera)
    out = tmp_path / "out"
    result = _invoke(ball, "-m", "least_squares", "--camera", tmp_path / "K.txt", "-o", out)
    assert result.exit_code == 0, result.output
    normals = np.load(out / "normals.npy")
    mask = datasets.load_diligent(ball).mask
    expected = bilateral_integration(normals, mask, camera, pieces=PIECES).depth
    np.testing.assert_allclose(np.load(out / "depth.npy"), expected)
    refused = _invoke(ball, "--integration", "frankot_chellappa", "--camera", tmp_path / "K.txt")
    assert refused.exit_code == 2 and "--camera needs --integration" in refused.output


def test_psm_gray_with_chrome_calibration(shared_data, tmp_path):
    psm = shared_data / "photometric_stereo" / "psm"
    out = tmp_path / "gray"
    result = _invoke(
        psm / "gray", "--chrome", psm / "chrome", "-m", "least_squares", "--step", "4", "-o", out
    )
    assert result.exit_code == 0, result.output
    chrome = datasets.load_psm(psm / "chrome", step=4)
    lights = calibrate_lights_chrome_sphere(chrome.images, chrome.mask)
    np.testing.assert_allclose(np.loadtxt(out / "lights.txt"), lights, atol=1e-8)
    error = np.load(out / "angular_error.npy")
    # Measured 6.4° mean at full resolution (the test_photometric_stereo bound).
    assert np.nanmean(error) < 7.5
    assert f"{np.nanmean(error):.2f}" in result.output


def test_bad_input_writes_nothing(ball, tmp_path):
    out = tmp_path / "out"
    assert _invoke(tmp_path / "missing", "-o", out).exit_code == 2
    assert _invoke(ball, "--method", "magic", "-o", out).exit_code == 2
    assert (
        _invoke(ball, "--integration", "poisson_dct", "--camera", ball / "x", "-o", out).exit_code
        == 2
    )
    (ball / "005.png").write_bytes(b"broken")
    result = _invoke(ball, "-o", out)
    assert result.exit_code == 2
    assert "005.png" in result.output
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [ball]
