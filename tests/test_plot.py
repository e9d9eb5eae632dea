"""Plots: their data against closed forms, and that every figure draws."""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from brdfkit import plot
from brdfkit.brdf import Lambertian, parse
from brdfkit.lights import DirectionalLight


def test_lobe_data_of_lambertian_is_rho_over_pi_times_cosine():
    theta, value = plot.lobe_data(Lambertian(0.6), math.radians(30), cosine=True)
    np.testing.assert_allclose(value, 0.6 / math.pi * np.clip(np.cos(theta), 0, None), atol=1e-12)


def test_lobe_data_peaks_at_the_mirror_direction_for_modified_phong():
    theta_i = math.radians(40)
    theta, value = plot.lobe_data(parse("modified_phong(kd=0, ks=1, n=200)"), theta_i)
    assert abs(theta[np.argmax(value)] - theta_i) < math.radians(1)
    peak = (200 + 2) / (2 * math.pi)  # ρs (n+2)/(2π) cos⁰ at the mirror direction
    assert abs(value.max() - peak) / peak < 1e-3


def test_half_diff_slice_of_lambertian_is_flat_and_albedo_curve_is_rho():
    _, _, value = plot.half_diff_data(Lambertian(0.5), resolution=30)
    finite = value[np.isfinite(value)]
    np.testing.assert_allclose(finite, 0.5 / math.pi, rtol=1e-12)
    _, rho, err = plot.albedo_data(Lambertian(0.5), angles=5)
    np.testing.assert_allclose(rho, 0.5, rtol=1e-12)
    assert np.all(err == 0)


def test_rendered_lambertian_sphere_matches_closed_form_through_the_display_pipeline():
    d = np.array([1.0, 0.3, 0.4])
    d /= np.linalg.norm(d)
    (image,) = plot.sphere_images([Lambertian(1.0)], DirectionalLight(d, math.pi), 64, exposure=0.0)
    from brdfkit.io import srgb_decode
    from brdfkit.render import Sphere, gbuffer

    g = gbuffer(Sphere(), None, 64)
    expected = np.clip(g.normals @ d, 0, 1) * g.mask  # ρ/π · π · cos = cos
    # 8-bit quantisation: half a code times the sRGB decode's largest slope (2.4/1.055).
    quantisation = 0.5 / 255 * 2.4 / 1.055
    np.testing.assert_allclose(srgb_decode(image[..., 0] / 255.0), expected, atol=quantisation)


@pytest.mark.parametrize(
    "draw",
    [
        lambda m: plot.lobe_plot(m, [0.0, 0.5], log=True),
        lambda m: plot.lobe_3d(m, 0.5, resolution=16),
        lambda m: plot.half_diff_plot(m, resolution=20),
        lambda m: plot.albedo_plot([m, Lambertian(0.3)], samples=64, angles=4),
        lambda m: plot.sphere_gallery([m], DirectionalLight((1, 0, 0)), resolution=16, samples=4),
    ],
    ids=["lobe", "lobe3d", "half-diff", "albedo", "spheres"],
)
def test_every_figure_draws(draw, tmp_path):
    fig = draw(parse("lambertian(albedo=0.3) + blinn_phong(n=30)"))
    plot.save(fig, tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 1000
