"""Diffuse/specular separation on renders whose two lobes are known separately."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import Lambertian, parse
from brdfkit.light import DirectionalLight
from brdfkit.render import Sphere, gbuffer, shade
from brdfkit.vision.separation import (
    max_chromaticity,
    separate_dichromatic,
    separate_polarization,
    specular_free,
)

SIZE = 64


def _psnr(estimate, truth, mask):
    return 10 * np.log10(truth[mask].max() ** 2 / np.mean((estimate - truth)[mask] ** 2))


@pytest.fixture(scope="module", params=["blinn_phong(kd=0, ks=0.3, n=60)", "0.3 * ggx(alpha=0.15)"])
def scene(request):
    """A two-coloured Lambertian sphere plus a grey specular lobe (Blinn–Phong, or a GGX
    microfacet lobe), each lobe rendered alone."""
    g = gbuffer(Sphere(), None, SIZE)
    left = np.arange(SIZE)[None, :, None] < SIZE // 2
    albedo = np.where(left, [0.7, 0.3, 0.1], [0.15, 0.3, 0.6]) * np.ones((SIZE, 1, 1))
    light = DirectionalLight(direction=(1.0, 0.3, 0.4), irradiance=[2.0, 1.6, 1.2])
    diffuse = shade(g, Lambertian(albedo), light)
    # A grey specular lobe under the coloured light reflects the light's colour.
    specular = shade(g, parse(request.param), light)
    return g.mask, diffuse, specular, np.array([2.0, 1.6, 1.2])


def test_specular_free_image_removes_a_white_specular(scene):
    _, diffuse, specular, illuminant = scene
    free = specular_free(diffuse + specular, illuminant)
    np.testing.assert_allclose(free, specular_free(diffuse, illuminant), atol=1e-12)


def test_dichromatic_separation(scene):
    mask, diffuse, specular, illuminant = scene
    image = diffuse + specular
    result = separate_dichromatic(image, illuminant)
    np.testing.assert_allclose(result.diffuse + result.specular, image, atol=1e-12)
    # Measured: diffuse 31.9 dB (Blinn–Phong; the input is 8.7 dB from it) and 34.0 dB (GGX);
    # specular 6.9 % and 5.5 % relative error.
    assert _psnr(result.diffuse, diffuse, mask) > 30
    assert _psnr(result.diffuse, diffuse, mask) > _psnr(image, diffuse, mask) + 20
    relative = np.linalg.norm((result.specular - specular)[mask]) / np.linalg.norm(specular[mask])
    assert relative < 0.08


def test_wrong_illuminant_is_worse(scene):
    mask, diffuse, specular, illuminant = scene
    image = diffuse + specular
    right = separate_dichromatic(image, illuminant)
    white = separate_dichromatic(image)
    assert _psnr(right.diffuse, diffuse, mask) > _psnr(white.diffuse, diffuse, mask)


def test_polarisation_pair(scene):
    mask, diffuse, specular, _ = scene
    rng = np.random.default_rng(0)
    parallel = diffuse / 2 + specular
    crossed = diffuse / 2
    result = separate_polarization(parallel, crossed)
    np.testing.assert_allclose(result.diffuse, diffuse, atol=1e-12)
    np.testing.assert_allclose(result.specular, specular, atol=1e-12)
    noise = 0.002
    noisy = separate_polarization(
        np.clip(parallel + rng.normal(0, noise, parallel.shape), 0, None),
        np.clip(crossed + rng.normal(0, noise, crossed.shape), 0, None),
    )
    assert _psnr(noisy.diffuse, diffuse, mask) > 40
    assert np.all(noisy.specular >= 0)


def test_max_chromaticity_of_white_and_pure_colours():
    image = np.array([[[1.0, 1.0, 1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 0.0]]])
    np.testing.assert_allclose(max_chromaticity(image), [[1 / 3, 1.0, 1 / 3]])


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="RGB"):
        separate_dichromatic(np.ones((4, 4)))
    with pytest.raises(ValueError, match="non-negative"):
        specular_free(-np.ones((4, 4, 3)))
    with pytest.raises(ValueError, match="illuminant"):
        separate_dichromatic(np.ones((4, 4, 3)), illuminant=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="same shape"):
        separate_polarization(np.ones((4, 4, 3)), np.ones((4, 5, 3)))
