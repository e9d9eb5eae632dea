"""One-sided sampling of BSDFs: only the hemisphere the lights of a one-sided render are in."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import MODELS, Lambertian, RoughDielectric, SmoothDielectric
from brdfkit.brdf.one_sided import OneSided, one_sided_view
from brdfkit.checks import brdf_sampler, chi2_test
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.light import EnvironmentMap, UniformSky
from brdfkit.render import reflected_radiance

ROUGH = RoughDielectric.examples()
IDS = [m.to_spec()[:60] for m in ROUGH]


def _direction(theta: float, phi: float = 0.3) -> np.ndarray:
    return np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )


@pytest.mark.parametrize("model", ROUGH, ids=IDS)
@pytest.mark.parametrize("side", [1.0, -1.0], ids=["outside", "inside"])
def test_rough_density_matches_sampler_and_weight(model, side):
    """χ² of sample_one_sided against pdf_one_sided (upper hemisphere only: all of the
    density), and weight = f·cos θi / pdf."""
    wo = _direction(0.8) * np.array([1.0, 1.0, side])
    view = one_sided_view(model)
    result = chi2_test(
        *brdf_sampler(view, wo), sample_dim=3, n_samples=40_000, test_count=2 * len(ROUGH)
    )
    result.assert_passed()
    s = view.sample(np.broadcast_to(wo, (2000, 3)), np.random.default_rng(1).random((2000, 3)))
    ok = s.pdf > 0
    assert np.all(s.wi[ok, 2] > 0) and np.all(s.weight[~ok] == 0)
    expected = model.eval(s.wi[ok], wo) * s.wi[ok, 2:3] / s.pdf[ok, None]
    np.testing.assert_allclose(s.weight[ok], expected, rtol=1e-10)


@pytest.mark.parametrize("model", ROUGH, ids=IDS)
def test_rough_unbiased_and_less_noisy(model):
    """Under a uniform sky the one-sided estimate equals quadrature of ∫_{H+} f cos (within
    its error), and its per-sample variance is below that of the BSDF's own sampler with the
    samples below the surface counted as 0 (what the render did before)."""
    wo = np.stack([_direction(t) for t in (0.2, 0.9, 1.3)] + [-_direction(0.4)])
    sky = UniformSky(1.0)
    exact = reflected_radiance(model, sky, wo, method="quadrature", theta_steps=256).value
    mc = reflected_radiance(model, sky, wo, method="brdf", samples=8192, seed=2)
    np.testing.assert_allclose(mc.value, exact, atol=5 * np.max(mc.stderr) + 1e-4)
    u = np.random.default_rng(3).random((4, 8192, 3))
    wo_n = np.broadcast_to(wo[:, None], (4, 8192, 3))
    old = model.sample(wo_n, u)
    old_w = np.where(old.wi[..., 2:3] > 0, old.weight, 0.0)
    new_w = one_sided_view(model).sample(wo_n, u).weight
    # same mean (both unbiased for the same integral), and less variance
    np.testing.assert_allclose(new_w.mean(1), old_w.mean(1), rtol=0.05, atol=2e-3)
    assert np.all(new_w.var(1) < old_w.var(1))


@pytest.mark.parametrize("model", SmoothDielectric.examples())
def test_smooth_dielectric_exact(model):
    """From outside F(θo)·L(mirror), from inside (1 − F)·s·L(refracted): no noise at all."""
    rng = np.random.default_rng(4)
    env = EnvironmentMap(rng.random((16, 32, 3)).astype(np.float32) + 0.1)
    wo = np.stack([_direction(0.3), _direction(1.2), -_direction(0.2)])
    est = reflected_radiance(model, env, wo, samples=8, seed=1)
    assert np.all(est.stderr <= 1e-12 * est.value)  # zero to rounding
    f = fresnel_dielectric(wo[:, 2], model.eta)
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    above = est.value[:2] / env.incident_radiance(np.zeros(3), mirror[:2])
    np.testing.assert_allclose(above, np.broadcast_to(f[:2, None], (2, 3)), rtol=1e-6)
    assert np.all(est.value[2] > 0)  # transmission towards a viewer inside


def test_views():
    """Non-transmitting models pass through; a view is made once per model; sums and scales
    wrap only their transmitting lobes."""
    ggx = MODELS["ggx"]()
    assert one_sided_view(ggx) is ggx
    glass = RoughDielectric()
    view = one_sided_view(glass)
    assert isinstance(view, OneSided) and one_sided_view(glass) is view
    mix = Lambertian(0.2) + 0.5 * glass
    view = one_sided_view(mix)
    assert view.lobes[0] is mix.lobes[0] and isinstance(view.lobes[1].inner, OneSided)
    assert not view.transmits
    with pytest.raises(TypeError, match="sample_one_sided"):
        OneSided(ggx)


@pytest.mark.slow
@pytest.mark.parametrize("model", [RoughDielectric(alpha=0.3), SmoothDielectric()])
def test_compiled_path_samples_one_sided_too(model):
    """The compiled shader compiles the same one-sided view: equal to the NumPy path."""
    from brdfkit.render import render_sphere

    env = EnvironmentMap(np.random.default_rng(5).random((16, 32, 3)) ** 4 * 5)
    numpy_path = render_sphere(model, env, 16, samples=8, compiled=False)
    compiled = render_sphere(model, env, 16, samples=8, compiled="float64")
    np.testing.assert_allclose(compiled, numpy_path, rtol=1e-11, atol=1e-13)
