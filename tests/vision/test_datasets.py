"""Photometric-stereo data sets: DiLiGenT round trip, psm layout, synthetic lights and shadows."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import datasets
from brdfkit.vision.photometric_stereo import sphere_normals


def _small(name: str = "ball") -> datasets.PhotometricStereoData:
    normals, mask = sphere_normals((20, 24), (11.5, 9.5), 8.0)
    lights = datasets.diligent_like_lights(3, 2, np.radians(30))
    intensities = np.linspace(0.5, 1.0, 18).reshape(6, 3)
    return datasets.render_synthetic(
        normals, mask, lights, albedo=[0.8, 0.6, 0.4], light_intensities=intensities, name=name
    )


def test_diligent_round_trip(tmp_path):
    data = _small()
    datasets.save_diligent(data, tmp_path / "ballPNG")
    raw = datasets.read_image(tmp_path / "ballPNG" / "002.png")
    assert raw.shape == (20, 24, 3)
    # The files hold the raw images (times the intensities), 16-bit.
    np.testing.assert_allclose(raw, data.images[1] * data.light_intensities[1], atol=1 / 65535)
    loaded = datasets.load_dataset(tmp_path / "ballPNG")
    assert loaded.name == "ball"
    np.testing.assert_array_equal(loaded.mask, data.mask)
    np.testing.assert_allclose(loaded.images, data.images, atol=2 / 65535)
    np.testing.assert_allclose(loaded.light_directions, data.light_directions, atol=1e-8)
    np.testing.assert_allclose(loaded.normals, data.normals)
    np.testing.assert_allclose(loaded.light_intensities, data.light_intensities, atol=1e-8)
    half = datasets.load_diligent(tmp_path / "ballPNG", step=2)
    assert half.images.shape == (6, 10, 12, 3)
    np.testing.assert_allclose(half.normals, data.normals[::2, ::2])


def test_psm_layout(shared_data):
    data = datasets.load_psm(shared_data / "photometric_stereo" / "psm" / "gray", step=4)
    assert data.images.shape == (12, 85, 128, 3)
    assert data.images.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(data.light_directions, axis=1), 1.0)
    assert np.all(data.light_directions[:, 2] > 0)  # lights face the object (z to the camera)
    np.testing.assert_allclose(np.linalg.norm(data.normals[data.mask], axis=1), 1.0, atol=1e-6)
    cat = datasets.load_dataset(shared_data / "photometric_stereo" / "psm" / "cat", step=4)
    assert cat.normals is None and cat.mask.any()


def test_diligent_like_lights():
    lights = datasets.diligent_like_lights()
    assert lights.shape == (96, 3)
    np.testing.assert_allclose(np.linalg.norm(lights, axis=1), 1.0)
    polar = np.degrees(np.arccos(lights[:, 2]))
    assert polar.max() == pytest.approx(45.0)
    assert lights[0, 0] < 0 and lights[0, 1] > 0  # first row: top left


def test_cast_shadows_of_a_wall():
    height = np.zeros((9, 9))
    height[:, 6] = 3.0  # a wall 3 pixels high in column 6
    towards_right = np.array([[1.0, 0.0, 1.0]])  # 45° elevation, to the right
    lit = datasets.cast_shadows(height, towards_right)[0]
    assert not lit[:, 4:6].any()  # less than 3 pixels left of the wall
    assert lit[:, :4].all() and lit[:, 6:].all()  # column 3 grazes the wall's top
    assert datasets.cast_shadows(height, np.array([[0.0, 0.0, 1.0]])).all()


def test_bad_files_are_named(tmp_path):
    data = _small()
    folder = tmp_path / "ballPNG"
    datasets.save_diligent(data, folder)
    (folder / "003.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match=r"003\.png"):
        datasets.load_diligent(folder)
    with pytest.raises(ValueError, match="neither a DiLiGenT folder"):
        datasets.load_dataset(tmp_path)
    with pytest.raises(ValueError, match="does not exist"):
        datasets.load_dataset(tmp_path / "missing")
    (folder / "filenames.txt").write_text("001.png\n002.png\n")
    with pytest.raises(ValueError, match="at least 3 images"):
        datasets.load_diligent(folder)
    (folder / "filenames.txt").write_text("\n".join(f"{k:03d}.png" for k in (1, 2, 4, 5)))
    with pytest.raises(ValueError, match=r"light_directions\.txt has 6 rows"):
        datasets.load_diligent(folder)
    with pytest.raises(ValueError, match="mask"):
        datasets.PhotometricStereoData(data.images, data.light_directions, ~np.ones((20, 24), bool))
