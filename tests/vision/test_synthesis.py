"""render_brdf: I = f_r E cos θ_i in each pixel's frame (closed forms, reciprocity of the
frame's use, and the tangent along the image x)."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.errors import ParameterError
from brdfkit.vision.datasets import diligent_like_lights
from brdfkit.vision.photometric_stereo import sphere_normals
from brdfkit.vision.synthesis import render_brdf, synthetic_set


def test_lambertian_images_are_rho_over_pi_times_cosine():
    normals, mask = sphere_normals((24, 24), (11.5, 11.5), 10.0)
    lights = diligent_like_lights(4, 3, np.radians(50))
    images = render_brdf(normals, mask, lights, parse("lambertian(rho=0.7)"), irradiance=2.0)
    expected = 2.0 * 0.7 / np.pi * np.clip(np.einsum("hwj,nj->nhw", normals, lights), 0, None)
    np.testing.assert_allclose(images[..., 0], expected * mask, rtol=1e-12, atol=1e-15)


def test_a_specular_lobe_peaks_where_the_normal_is_the_half_vector():
    normals, mask = sphere_normals((65, 65), (32.0, 32.0), 30.0)
    light = np.array([[0.3, 0.2, 1.0]]) / np.linalg.norm([0.3, 0.2, 1.0])
    image = render_brdf(normals, mask, light, parse("ggx(alpha=0.05)"))[0, ..., 0]
    half = (light[0] + [0, 0, 1]) / np.linalg.norm(light[0] + [0, 0, 1])
    row, column = np.unravel_index(np.argmax(image), image.shape)
    assert np.degrees(np.arccos(normals[row, column] @ half)) < 3.0


def test_anisotropic_tangent_runs_along_the_image_rows():
    normals = np.tile([0.0, 0.0, 1.0], (1, 2, 1))
    mask = np.ones((1, 2), bool)
    spec = "ward(ks=0.5, alpha_x=0.05, alpha_y=0.4)"
    along_x = render_brdf(normals, mask, [[0.5, 0.0, 1.0]], parse(spec))
    along_y = render_brdf(normals, mask, [[0.0, 0.5, 1.0]], parse(spec))
    assert along_y[0, 0, 0, 0] > 10 * along_x[0, 0, 0, 0]  # rough across y, sharp along x


def test_exposure_and_refusals():
    normals, mask = sphere_normals((16, 16), (7.5, 7.5), 7.0)
    lights = diligent_like_lights(3, 3, np.radians(30))
    data = synthetic_set(normals, mask, lights, parse("lambertian(rho=0.6)"), peak=0.8)
    assert np.isclose((data.images * data.light_intensities[:, None, None, :]).max(), 0.8)
    with pytest.raises(ParameterError, match="camera's side"):
        render_brdf(normals, mask, [[0.0, 0.0, -1.0]], parse("lambertian"))
    with pytest.raises(ParameterError, match="peak"):
        synthetic_set(normals, mask, lights, parse("lambertian"), peak=2.0)
