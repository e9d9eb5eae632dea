"""The explorer's views equal what the library computes, and its noise figure is honest."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.data import default_envmap_path
from brdfkit.explore import views
from brdfkit.light import EnvironmentMap
from brdfkit.render import gbuffer, progressive, render_sphere, shade

SPECS = [
    "lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)",
    "ggx(alpha_u=0.1, alpha_v=0.4)",
]


@pytest.mark.parametrize("spec", SPECS)
@pytest.mark.parametrize("angles", [(0.0, 0.0), (33.0, 10.0), (80.0, -120.0)])
def test_the_sphere_is_render_sphere(spec, angles):
    state = views.ViewState(theta_i=angles[0], phi_i=angles[1], resolution=64)
    brdf = parse(spec)
    reference = render_sphere(brdf, state.light(), resolution=64)
    np.testing.assert_allclose(views.sphere(brdf, state), reference, rtol=1e-12, atol=1e-15)
    assert reference.max() > 0


def test_the_compiled_sphere_is_render_sphere_and_a_preview_has_half_the_pixels():
    pytest.importorskip("numba")
    brdf = parse(SPECS[0])
    views.build_fast_eval(brdf)
    other = parse(SPECS[0].replace("alpha=0.2", "alpha=0.35"))  # a slider moved: same kernel
    assert views.fast_eval(other) is not other
    state = views.ViewState(theta_i=40.0, phi_i=25.0, resolution=128)
    reference = render_sphere(other, state.light(), resolution=128)
    np.testing.assert_allclose(views.sphere(other, state), reference, rtol=1e-12, atol=1e-15)
    preview = dataclasses.replace(state, preview=True)
    half = render_sphere(other, state.light(), resolution=64)
    np.testing.assert_allclose(views.sphere(other, preview), half, rtol=1e-12, atol=1e-15)


@pytest.fixture(scope="module")
def envmap():
    return EnvironmentMap.from_file(default_envmap_path())


@pytest.mark.slow
def test_the_diffuse_term_is_the_estimators_exact_part(envmap):
    brdf = parse("lambertian(albedo=[0.8, 0.4, 0.2])")  # all exact: shade needs no samples
    reference = shade(views.sphere_gbuffer(32), brdf, envmap, samples=1)
    np.testing.assert_allclose(views.diffuse_term(brdf, envmap, 32), reference, rtol=1e-6)
    assert views.diffuse_term(parse("ggx(alpha=0.2)"), envmap, 32) is None


@pytest.mark.slow
def test_the_noise_from_successive_passes_tracks_the_true_error(envmap):
    """relative_noise(p, mask) from the Sobol' replicates estimates the RMS error of the image
    against a converged reference; the per-sample stderr over-estimates it."""
    brdf = parse("lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)")
    g = gbuffer(views.Sphere(), None, 16)
    mask = g.mask
    reference = list(progressive(g, brdf, envmap, max_samples=1024, seed=99, compiled=False))
    reference = reference[-1].image
    passes = list(progressive(g, brdf, envmap, max_samples=64, compiled=False))
    assert [p.samples for p in passes] == [2, 4, 8, 16, 32, 64]
    for p in passes[2:]:  # 8, 16, 32, 64 spp
        mean = np.mean(p.image[mask])
        true = np.sqrt(np.mean((p.image[mask] - reference[mask]) ** 2)) / mean
        estimate = views.relative_noise(p, mask)
        assert 0.6 * true < estimate < 1.6 * true, (p.samples, estimate, true)
    conservative = views.relative_noise(dataclasses.replace(p, error=None), mask)
    assert conservative > 1.2 * estimate, (conservative, estimate)
