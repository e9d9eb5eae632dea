"""``brdfkit lighting / sfs / separate / hdr``: outputs match the library; bad input exits 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.brdf import Lambertian
from brdfkit.cli import app
from brdfkit.io import read_image, write_image
from brdfkit.light import DirectionalLight
from brdfkit.light.spherical_harmonics import irradiance_sh
from brdfkit.render import Sphere, gbuffer, normal_map_gbuffer, shade
from brdfkit.vision.separation import separate_dichromatic

runner = CliRunner()


def _invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture
def sphere_files(tmp_path):
    """An SH-lit Lambertian sphere (.exr), its normals (.npy) and mask (.png)."""
    rng = np.random.default_rng(1)
    coeffs = rng.normal(size=(9, 3)) * 0.3
    coeffs[0] += 4.0
    g = gbuffer(Sphere(), None, 32)
    image = (irradiance_sh(coeffs, g.normals) / np.pi * g.mask[..., None]).clip(0, None)
    write_image(tmp_path / "sphere.exr", image.astype(np.float32))
    np.save(tmp_path / "normals.npy", g.normals)
    write_image(tmp_path / "mask.png", g.mask.astype(np.float32), srgb=False)
    return tmp_path, coeffs


def test_lighting_sh_and_directional(sphere_files):
    folder, coeffs = sphere_files
    out = folder / "sh.json"
    result = _invoke(
        "lighting", folder / "sphere.exr", "--normals", folder / "normals.npy",
        "--mask", folder / "mask.png", "-o", out,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    record = json.loads(out.read_text())
    np.testing.assert_allclose(record["coefficients"], coeffs, rtol=1e-4, atol=1e-4)
    out = folder / "dir.json"
    result = _invoke(
        "lighting", folder / "sphere.exr", "--method", "directional",
        "--normals", folder / "normals.npy", "--mask", folder / "mask.png", "-o", out,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert np.linalg.norm(json.loads(out.read_text())["direction"]) == pytest.approx(1.0)


def test_lighting_mirror_ball(tmp_path):
    ball = np.ones((24, 24, 3), dtype=np.float32)
    write_image(tmp_path / "ball.exr", ball)
    result = _invoke("lighting", tmp_path / "ball.exr", "-m", "mirror-ball", "-o",
                     tmp_path / "env.exr", "--height", "16")  # fmt: skip
    assert result.exit_code == 0, result.output
    env = read_image(tmp_path / "env.exr")
    assert env.shape == (16, 32, 3)
    np.testing.assert_allclose(env, 1.0, rtol=1e-6)


def test_lighting_refuses_non_linear_and_missing_normals(sphere_files):
    folder, _ = sphere_files
    write_image(folder / "photo.png", np.full((32, 32, 3), 0.5, dtype=np.float32))
    result = _invoke("lighting", folder / "photo.png", "--normals", folder / "normals.npy")
    assert result.exit_code == 2
    assert "non-linear" in result.output
    result = _invoke("lighting", folder / "sphere.exr", "-o", folder / "x.json")
    assert result.exit_code == 2
    assert "--normals" in result.output
    assert not (folder / "x.json").exists()
    result = _invoke("lighting", folder / "sphere.exr", "--method", "magic")
    assert result.exit_code == 2


def test_sfs_writes_depth_and_normals(tmp_path):
    g = normal_map_gbuffer(*_small_sphere())
    light = DirectionalLight(direction=(0.0, 0.0, 1.0), irradiance=np.pi)
    image = shade(g, Lambertian(1.0), light)
    write_image(tmp_path / "img.exr", np.repeat(image, 3, axis=-1).astype(np.float32))
    write_image(tmp_path / "mask.png", g.mask.astype(np.float32), srgb=False)
    out = tmp_path / "sfs"
    result = _invoke("sfs", tmp_path / "img.exr", "--light", "0,0,1", "--mask",
                     tmp_path / "mask.png", "-o", out)  # fmt: skip
    assert result.exit_code == 0, result.output
    normals = np.load(out / "normals.npy")
    cosine = np.sum(normals * g.normals, axis=-1)[g.mask]
    assert np.median(np.degrees(np.arccos(np.clip(cosine, -1, 1)))) < 2.0
    assert np.isnan(np.load(out / "depth.npy")[~g.mask]).all()
    assert (out / "normals.png").is_file()
    result = _invoke("sfs", tmp_path / "img.exr", "--light", "0,1", "-o", tmp_path / "bad")
    assert result.exit_code == 2
    assert not (tmp_path / "bad").exists()


def _small_sphere(size=24, radius=10.0):
    centre = size / 2 - 0.5
    x, y = np.meshgrid(np.arange(size) - centre, centre - np.arange(size))
    mask = x**2 + y**2 < (radius - 0.5) ** 2
    z = np.sqrt(np.clip(radius**2 - x**2 - y**2, 0, None))
    return np.where(mask[..., None], np.stack([x, y, z], axis=-1) / radius, 0.0), mask


def test_separate_dichromatic_and_polarisation(tmp_path):
    rng = np.random.default_rng(2)
    image = (rng.uniform(0.1, 0.5, (16, 16, 3)) * [1.0, 0.5, 0.2]).astype(np.float32)
    write_image(tmp_path / "img.exr", image)
    result = _invoke("separate", tmp_path / "img.exr", "-o", tmp_path / "dich")
    assert result.exit_code == 0, result.output
    expected = separate_dichromatic(image)
    np.testing.assert_allclose(read_image(tmp_path / "dich" / "diffuse.exr"), expected.diffuse,
                               rtol=1e-6, atol=1e-7)  # fmt: skip
    write_image(tmp_path / "crossed.exr", image / 2)
    result = _invoke("separate", tmp_path / "img.exr", "--crossed", tmp_path / "crossed.exr",
                     "-o", tmp_path / "pol")  # fmt: skip
    assert result.exit_code == 0, result.output
    np.testing.assert_allclose(read_image(tmp_path / "pol" / "diffuse.exr"), image, rtol=1e-6)
    np.testing.assert_allclose(read_image(tmp_path / "pol" / "specular.exr"), image / 2, rtol=1e-6)
    write_image(tmp_path / "small.exr", image[:8])
    result = _invoke("separate", tmp_path / "img.exr", "--crossed", tmp_path / "small.exr",
                     "-o", tmp_path / "bad")  # fmt: skip
    assert result.exit_code == 2
    assert "same shape" in result.output
    assert not (tmp_path / "bad").exists()


def test_hdr_merges_a_stack(tmp_path):
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(3)
    radiance = np.exp(rng.uniform(-3, 3, (40, 40, 3)))
    times = [1 / 64, 1 / 16, 1 / 4, 1.0, 4.0]
    paths = []
    for k, t in enumerate(times):
        codes = np.round(255 * np.clip(radiance * t, 0, 1) ** (1 / 2.2)).astype(np.uint8)
        paths.append(tmp_path / f"e{k}.png")
        cv2.imwrite(str(paths[-1]), codes[..., ::-1])
    out = tmp_path / "merged.exr"
    result = _invoke("hdr", *paths, "--times", ",".join(map(str, times)), "-o", out,
                     "--response", tmp_path / "g.csv")  # fmt: skip
    assert result.exit_code == 0, result.output
    merged = read_image(out).astype(np.float64)
    ratio = np.log(merged / radiance)
    assert np.std(ratio) < 0.05  # radiance up to one global scale
    assert np.loadtxt(tmp_path / "g.csv", delimiter=",").shape == (256, 3)
    result = _invoke("hdr", *paths[:2], "--times", "1", "-o", tmp_path / "bad.exr")
    assert result.exit_code == 2
    assert "times" in result.output
    result = _invoke("hdr", out, paths[0], "--times", "1,2", "-o", tmp_path / "bad.exr")
    assert result.exit_code == 2
    assert "linear" in result.output
    assert not (tmp_path / "bad.exr").exists()
