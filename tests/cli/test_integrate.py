"""``brdfkit integrate``: the three files from a folder in the bilateral-integration layout,
NaN outside the mask, the library's depth, a depth prior's units; bad input refused in one
line, nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.cli.integrate import _METHODS
from brdfkit.io import read_image, write_image
from brdfkit.vision import datasets
from brdfkit.vision.bilateral_integration import PIECES, PRIOR_WEIGHT, bilateral_integration
from brdfkit.vision.depth_from_normals import METHODS

runner = CliRunner()
CAMERA = np.array([[40.0, 0.0, 10.0], [0.0, 40.0, 8.0], [0.0, 0.0, 1.0]])


def _invoke(*args):
    return runner.invoke(app, ["integrate", *(str(a) for a in args)])


@pytest.fixture
def folder(tmp_path):
    """A hemisphere in front of the camera: normal_map.png (16-bit), mask.png and K.txt."""
    rows, columns = np.indices((16, 20)).astype(np.float64)
    x, y = (columns - 9.5) / 7.0, -(rows - 7.5) / 7.0
    mask = x**2 + y**2 < 0.8
    normals = np.stack([x, y, np.sqrt(np.clip(1 - x**2 - y**2, 0, None))], -1)
    normals = np.where(mask[..., None], normals, 0.0)
    path = tmp_path / "sphere"
    path.mkdir()
    datasets.write_normal_map(path / "normal_map.png", normals)
    write_image(path / "mask.png", mask.astype(np.float64), srgb=False)
    np.savetxt(path / "K.txt", CAMERA)
    return path


def test_writes_depth_exr_and_mesh_from_a_folder(folder, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    out = tmp_path / "out"
    result = _invoke(folder, "-o", out, "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["projection"] == "perspective"
    assert summary["method"] == "bilateral_pieces"
    depth = np.load(out / "depth.npy")
    mask = datasets.read_mask(folder / "mask.png")
    assert np.isnan(depth[~mask]).all() and np.isfinite(depth[mask]).all()
    assert summary["pixels"] == mask.sum()
    normals = datasets.read_normal_map(folder / "normal_map.png")
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    expected = bilateral_integration(normals, mask, CAMERA, pieces=PIECES).depth
    assert np.allclose(depth, expected, equal_nan=True)
    exr = read_image(out / "depth.exr")[..., 0]
    assert np.allclose(exr, depth.astype(np.float32), equal_nan=True)
    mesh = trimesh.load(out / "mesh.ply", process=False)
    assert len(mesh.vertices) == mask.sum() and len(mesh.faces) > 0
    # the sphere bulges towards the camera: its centre is nearer than its rim, by about
    # (1 - sqrt(0.2)) 7/40 ≈ 10 % of the depth (rim at x² + y² = 0.8, radius 7 px, f = 40)
    assert np.nanmax(depth) - depth[8, 10] > 0.05 * depth[8, 10]


def test_a_bad_k_file_is_refused_in_one_line_naming_it(folder, tmp_path):
    out = tmp_path / "out"
    bad = tmp_path / "K.txt"
    bad.write_text("1 2 3\n")
    result = _invoke(
        folder / "normal_map.png", "--mask", folder / "mask.png", "--K", bad, "-o", out
    )
    assert result.exit_code == 2
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(bad) in lines[0]
    assert not out.exists()


def test_orthographic_only_methods_refuse_k_and_unknown_methods(folder, tmp_path):
    out = tmp_path / "out"
    result = _invoke(folder, "--method", "poisson_dct", "-o", out)
    assert result.exit_code == 2 and "orthographic only" in result.stderr
    assert _invoke(folder, "--method", "magic", "-o", out).exit_code == 2
    assert not out.exists()


def test_orthographic_without_k_and_the_method_list(folder, tmp_path):
    out = tmp_path / "out"
    image = folder / "normal_map.png"
    result = _invoke(image, "--mask", folder / "mask.png", "-m", "least_squares", "-o", out)
    assert result.exit_code == 0, result.output
    depth = np.load(out / "depth.npy")
    assert np.nanmin(depth) == 0.0  # orthographic: nearest pixel at 0, pixel units
    assert set(_METHODS) == set(METHODS)


@pytest.mark.parametrize("stored", ["png", "npy"])
def test_without_a_mask_the_object_is_where_the_map_holds_normals(folder, tmp_path, stored):
    """``brdfkit ps``'s outputs: zeros outside the object (``.npy``), mid-grey (``.png``)."""
    mask = datasets.read_mask(folder / "mask.png")
    source = folder / "normal_map.png"
    if stored == "npy":
        source = tmp_path / "normals.npy"
        np.save(source, datasets.read_normal_map(folder / "normal_map.png") * mask[..., None])
    masked, inferred = tmp_path / "masked", tmp_path / "inferred"
    assert _invoke(source, "--mask", folder / "mask.png", "-o", masked).exit_code == 0
    result = _invoke(source, "-o", inferred, "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["pixels"] == mask.sum()
    depth = np.load(inferred / "depth.npy")
    assert np.array_equal(np.isfinite(depth), mask)
    assert np.allclose(depth, np.load(masked / "depth.npy"), equal_nan=True)


def test_a_map_without_normals_and_no_mask_is_refused_naming_it(tmp_path):
    empty = tmp_path / "empty.npy"
    np.save(empty, np.zeros((6, 7, 3)))
    out = tmp_path / "out"
    result = _invoke(empty, "-o", out)
    assert result.exit_code == 2
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and str(empty) in lines[0] and "give a mask" in lines[0]
    assert not out.exists()


def test_a_depth_prior_sets_the_units_and_is_the_library_s(folder, tmp_path):
    """Depth known at a few pixels, in mm: the depth comes out in mm, as the library gives it,
    and the known depths are reported."""
    first, second = tmp_path / "first", tmp_path / "second"
    assert _invoke(folder, "-o", first).exit_code == 0
    relative = np.load(first / "depth.npy")  # geometric mean 1
    prior = np.full(relative.shape, np.nan)
    prior[6:10:2, 8:12:2] = 1500.0 * relative[6:10:2, 8:12:2]  # 4 depths, 1.5 m away
    np.save(tmp_path / "prior.npy", prior)
    result = _invoke(folder, "--prior", tmp_path / "prior.npy", "-o", second, "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["prior_depths"] == 4
    depth = np.load(second / "depth.npy")
    assert np.allclose(depth, 1500.0 * relative, rtol=1e-3, equal_nan=True)
    mask = datasets.read_mask(folder / "mask.png")
    normals = datasets.read_normal_map(folder / "normal_map.png")
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    expected = bilateral_integration(normals, mask, CAMERA, depth_prior=prior, pieces=PIECES).depth
    assert np.allclose(depth, expected, equal_nan=True)
    write_image(tmp_path / "prior.exr", prior[..., None].astype(np.float32), nan_marks_missing=True)
    again = _invoke(folder, "--prior", tmp_path / "prior.exr", "-o", second)
    assert again.exit_code == 0, again.output
    assert np.allclose(np.load(second / "depth.npy"), depth, rtol=1e-6, equal_nan=True)
    assert PRIOR_WEIGHT == 0.01  # the default of --prior-weight, written out for --help


@pytest.mark.parametrize(
    ("prior", "options", "message"),
    [
        (np.full((16, 20), np.nan), (), "no depth is known inside the mask"),
        (np.full((16, 20), -1.0), (), "must be positive"),
        (np.ones((8, 8)), (), "the prior is (8, 8)"),
        (np.ones((16, 20)), ("-m", "least_squares"), "a depth prior needs method one of"),
    ],
)
def test_a_bad_prior_is_refused_in_one_line(folder, tmp_path, prior, options, message):
    np.save(tmp_path / "prior.npy", prior)
    out = tmp_path / "out"
    result = _invoke(folder, "--prior", tmp_path / "prior.npy", *options, "-o", out)
    assert result.exit_code == 2
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr
    assert not out.exists()
