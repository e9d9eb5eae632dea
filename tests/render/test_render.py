"""Rendering: closed-form spheres, cameras, tiles, per-pixel parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Lambertian
from brdfkit.light import DirectionalLight, PointLight, UniformSky
from brdfkit.render import (
    Camera,
    Cylinder,
    Plane,
    Sphere,
    gbuffer,
    normal_map_gbuffer,
    render_sphere,
    shade,
)


def test_lambertian_sphere_under_directional_light_matches_closed_form_per_pixel():
    d = np.array([1.0, 0.5, 0.7])
    d /= np.linalg.norm(d)
    img = render_sphere(Lambertian([0.8, 0.5, 0.2]), DirectionalLight(d, 2.0), resolution=96)
    g = gbuffer(Sphere(), None, 96)
    expected = (
        np.array([0.8, 0.5, 0.2]) / math.pi * 2.0 * np.clip(g.normals @ d, 0, None)[..., None]
    )
    np.testing.assert_allclose(img, np.where(g.mask[..., None], expected, 0), atol=1e-12)
    # the silhouette is the inscribed disk
    assert abs(g.mask.mean() - math.pi / 4) < 0.02


def test_tiles_do_not_change_the_image_and_svbrdf_parameters_are_sliced():
    g = gbuffer(Sphere(), None, 40)
    rng = np.random.default_rng(0)
    texture = rng.random((40, 40, 3))
    light = DirectionalLight((1, 0.2, 0.3), 1.0)
    whole = shade(g, Lambertian(texture), light, max_evaluations=10**9)
    tiled = shade(g, Lambertian(texture), light, max_evaluations=40 * 3)
    np.testing.assert_allclose(tiled, whole, atol=0)
    d = np.array([1, 0.2, 0.3]) / np.linalg.norm([1, 0.2, 0.3])
    expected = texture / math.pi * np.clip(g.normals @ d, 0, None)[..., None]
    np.testing.assert_allclose(whole, np.where(g.mask[..., None], expected, 0), atol=1e-12)


def test_sobol_pixels_keep_their_sequences_whatever_the_tiles():
    """A pixel's Sobol' seed hashes its index in the image: tiles and first_sample blocks do
    not change its samples (so progressive passes can continue them)."""
    from brdfkit.brdf import RoughConductor
    from brdfkit.light import EnvironmentMap
    from brdfkit.render.shading import _shade

    g = gbuffer(Sphere(), None, 12)
    env = EnvironmentMap(np.random.default_rng(1).random((8, 16, 3)) ** 3 * 4)
    gold = RoughConductor(alpha=0.3, material="Au", masking="smith_separable")
    kwargs = {"seed": 3, "compiled": False}
    whole = shade(g, gold, env, samples=8, **kwargs)
    tiled = shade(g, gold, env, samples=8, max_evaluations=(16 + 16) * 12 * 2, **kwargs)
    np.testing.assert_allclose(tiled, whole, rtol=1e-12, atol=1e-15)
    options = {"method": "auto", "sequence": "sobol", "max_evaluations": 500_000,
               "background": 0.0, "progress": None}  # fmt: skip
    halves = [
        _shade(g, gold, env, samples=4, first_sample=first, **options, **kwargs)[0]
        for first in (0, 4)
    ]
    np.testing.assert_allclose((halves[0] + halves[1]) / 2, whole, rtol=1e-12, atol=1e-15)


def test_point_light_on_a_plane_falls_off_with_inverse_square():
    cam = Camera.look_at((0, 0, 5.0), (0, 0, 0), up=(0, 1, 0), extent=4.0)
    g = gbuffer(Plane(point=(0, 0, 0), normal=(0, 0, 1), tangent=(1, 0, 0)), cam, 33)
    img = shade(g, Lambertian(1.0), PointLight((0, 0, 1.0), 1.0))
    r2 = np.sum(g.points**2, axis=-1) + 1.0
    expected = 1.0 / r2 * (1 / np.sqrt(r2)) / math.pi
    np.testing.assert_allclose(img[..., 0], expected, rtol=1e-10)


def test_perspective_camera_sees_a_sphere_and_a_cylinder():
    cam = Camera.look_at((6, 0, 0), kind="perspective", fov=math.radians(30))
    g = gbuffer(Sphere(radius=1.0), cam, 64)
    assert g.mask.any() and not g.mask.all()
    np.testing.assert_allclose(np.linalg.norm(g.normals[g.mask], axis=-1), 1, atol=1e-9)
    # every visible normal faces the camera
    assert np.all(np.sum(g.normals[g.mask] * g.wo[g.mask], axis=-1) > -1e-9)
    gc = gbuffer(Cylinder(), Camera(), 64)
    assert abs(gc.normals[gc.mask][:, 2]).max() < 1e-9


def test_normal_map_render_and_errors():
    n = np.zeros((4, 5, 3))
    n[..., 2] = 1
    g = normal_map_gbuffer(n)
    img = shade(g, Lambertian(0.5), UniformSky(1.0), method="quadrature")
    np.testing.assert_allclose(img, 0.5, rtol=1e-6)
    with pytest.raises(ValueError, match="normals must have shape"):
        normal_map_gbuffer(np.zeros((4, 5)))
    with pytest.raises(ValueError, match="mask must have shape"):
        normal_map_gbuffer(n, np.ones((2, 2), bool))


@pytest.mark.slow
def test_2048_render_under_an_environment_map_holds_a_few_hundred_mb():
    """A 2048² Monte Carlo render goes band by band (G-buffer) and tile by tile (samples):
    its peak is the image (100 MB) and one tile, below 400 MB."""
    import tracemalloc

    from brdfkit.brdf import RoughConductor
    from brdfkit.light import EnvironmentMap

    env = EnvironmentMap(np.random.default_rng(0).random((64, 128, 3)))
    _ = env.irradiance_table
    tracemalloc.start()
    img = render_sphere(RoughConductor(alpha=0.3), env, resolution=2048, samples=1, compiled=False)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert img.shape == (2048, 2048, 3) and np.all(np.isfinite(img))
    assert peak < 400_000_000, f"peak {peak / 1e6:.0f} MB"


def test_render_sphere_in_bands_equals_one_g_buffer(monkeypatch):
    from brdfkit.brdf import RoughConductor
    from brdfkit.light import EnvironmentMap
    from brdfkit.render import shading

    env = EnvironmentMap(np.random.default_rng(1).random((16, 32, 3)))
    brdf = Lambertian(0.3) + RoughConductor(alpha=0.4)
    kwargs = {"samples": 4, "seed": 7, "max_evaluations": 36 * 5 * 4, "compiled": False}
    whole = shade(gbuffer(Sphere(), None, 36), brdf, env, **kwargs)
    monkeypatch.setattr(shading, "BAND_PIXELS", 36 * 10)  # bands of 2 tiles of 5 rows
    np.testing.assert_array_equal(render_sphere(brdf, env, 36, **kwargs), whole)
