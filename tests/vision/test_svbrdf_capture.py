"""The SVBRDF capture pipeline (:mod:`brdfkit.vision.svbrdf_capture`): the fit on the images not
held out, renders under new lights, the held-out comparison with the Lambertian model, and the
refusals of bad arguments and light files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.errors import FormatError, ParameterError
from brdfkit.vision import datasets, svbrdf
from brdfkit.vision.photometric_stereo import least_squares, sphere_normals
from brdfkit.vision.svbrdf_capture import capture_svbrdf, read_light_directions


@pytest.fixture(scope="module")
def glossy():
    """A small glossy sphere under 12 lights."""
    normals, mask = sphere_normals((16, 16), (7.5, 7.5), 7.0)
    lights = datasets.diligent_like_lights(4, 3, np.radians(30))
    return datasets.render_synthetic(
        normals, mask, lights, albedo=[0.6, 0.4, 0.3], specular=0.5, shininess=20.0
    )


def test_the_capture_equals_its_steps(glossy):
    new_lights = np.array([[0.0, 0.0, 1.0], [0.3, 0.2, 0.9]])
    stages = []
    capture = capture_svbrdf(
        glossy, lobes=1, hold_out=[2, 7], relight=new_lights, progress=stages.append
    )
    assert capture.train == [0, 1, 3, 4, 5, 6, 8, 9, 10, 11] and capture.held_out == [2, 7]
    assert stages == ["fitting 1 lobe(s)"]
    images = glossy.images.astype(np.float64)
    lights = glossy.light_directions
    fit = svbrdf.fit_svbrdf(images[capture.train], lights[capture.train], glossy.mask, lobes=1)
    np.testing.assert_array_equal(capture.fit.normals, fit.normals)
    np.testing.assert_array_equal(capture.relit, fit.relight(new_lights))
    rendered = fit.relight(lights[[2, 7]])
    np.testing.assert_array_equal(capture.held_out_renders, rendered)
    ls = least_squares(images[capture.train], lights[capture.train], glossy.mask)
    lambert = svbrdf.lambertian_relight(ls.albedo, ls.normals, glossy.mask, lights[[2, 7]])
    real = images[[2, 7]][:, glossy.mask]
    rms = capture.relighting_rms
    assert rms["svbrdf"] == float(np.sqrt(np.mean((rendered[:, glossy.mask] - real) ** 2)))
    assert rms["lambertian"] == float(np.sqrt(np.mean((lambert[:, glossy.mask] - real) ** 2)))
    assert rms["svbrdf"] < rms["lambertian"]  # the highlights are what the lobe explains
    summary = capture.summary()
    assert summary["lobes"] == 1 and summary["held_out"] == [2, 7]
    assert "shadow_bias" not in summary and "cross_validated_rms" not in summary


def test_cast_shadows_choose_a_bias(glossy):
    capture = capture_svbrdf(glossy, lobes=0, cast_shadows=True)
    assert capture.shadow_bias in svbrdf.SHADOW_BIASES
    expected = None if math.isinf(capture.shadow_bias) else capture.shadow_bias
    assert capture.summary()["shadow_bias"] == expected


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"hold_out": [1, 1]}, "distinct images"),
        ({"hold_out": [12]}, "distinct images in 0..11"),
        ({"hold_out": list(range(10))}, "leaves 2 images"),
        ({"lobes": 5}, "lobes must be 0 to 4"),
        ({"lobes": "two"}, "lobes must be 0 to 4"),
    ],
)
def test_bad_arguments_are_refused(glossy, options, message):
    with pytest.raises(ParameterError, match=message):
        capture_svbrdf(glossy, **options)


@pytest.mark.parametrize(
    ("text", "message"),
    [("1 2\n3 4\n", "expected finite rows"), ("0 0 0\n", "is zero"), ("a b c\n", "numbers")],
)
def test_bad_light_files_are_refused(tmp_path, text, message):
    path = tmp_path / "lights.txt"
    path.write_text(text)
    with pytest.raises(FormatError, match=message):
        read_light_directions(path)
    path.write_text("0 0 2\n1 0 1\n")
    np.testing.assert_array_equal(read_light_directions(path), [[0, 0, 2], [1, 0, 1]])
