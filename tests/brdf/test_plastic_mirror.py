"""A smooth plastic's mirror taken exactly under an environment map (integrate.split_mirror)."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf.plastic import SmoothPlastic
from brdfkit.data import default_envmap_path
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.light import EnvironmentMap
from brdfkit.render import Sphere, gbuffer, reflected_radiance, split_mirror


@pytest.fixture(scope="module")
def scene():
    env = EnvironmentMap.from_file(default_envmap_path())
    g = gbuffer(Sphere(), None, 12)
    m = g.mask
    return env, g.wo[m], g.normals[m], g.tangents[m]


def _radiance(model, scene, **kwargs):
    env, wo, n, t = scene
    return reflected_radiance(model, env, wo, normal=n, tangent=t, **kwargs)


def test_split_mirror_only_smooth_plastic_with_a_coating():
    plastic = SmoothPlastic(diffuse_reflectance=0.3)
    mirror, base = split_mirror(plastic)
    assert mirror is plastic and base.specular_reflectance == 0.0
    assert split_mirror(SmoothPlastic(specular_reflectance=0.0))[0] is None


def test_mirror_alone_is_exact_closed_form(scene):
    """ρ = 0: the image is s F(θo) L(ωr), no Monte Carlo (zero stderr)."""
    env, wo, n, _ = scene
    model = SmoothPlastic(diffuse_reflectance=0.0, specular_reflectance=0.7, eta=1.5)
    estimate = _radiance(model, scene, samples=4, seed=3)
    cos_o = np.sum(wo * n, axis=-1)
    r = 2 * cos_o[:, None] * n - wo
    expected = 0.7 * fresnel_dielectric(cos_o, 1.5)[:, None] * env.incident_radiance(0 * r, r)
    np.testing.assert_allclose(estimate.value, expected, rtol=1e-9, atol=1e-12)
    assert np.all(estimate.stderr == 0)


def test_equals_plain_mis_in_expectation(scene):
    """The split estimator (auto) against plain MIS of the whole plastic (the sampler's random
    mirror-or-diffuse choice), converged: within 4 of MIS's standard errors, per pixel."""
    model = SmoothPlastic(diffuse_reflectance=[0.8, 0.3, 0.1], eta=1.5)
    split = _radiance(model, scene, samples=256, seed=1, sequence="sobol")
    plain = _radiance(model, scene, method="mis", samples=4096, seed=2)
    error = np.hypot(split.stderr, plain.stderr)
    assert np.all(np.abs(split.value - plain.value) <= 4 * error + 1e-9)
    # and much less noisy at equal samples: the lobe choice was most of the variance
    split = _radiance(model, scene, samples=256, seed=1)
    plain = _radiance(model, scene, method="mis", samples=256, seed=1)
    assert np.median(split.stderr) < 0.5 * np.median(plain.stderr)


def test_compiled_float64_equals_numpy(scene):
    pytest.importorskip("numba")
    from brdfkit.render.compiled_shading import reflected_radiance as compiled_radiance

    env, wo, n, t = scene
    model = SmoothPlastic(diffuse_reflectance=0.5)
    kwargs = dict(normal=n, tangent=t, samples=8, seed=4, sequence="sobol")
    numpy_path = reflected_radiance(model, env, wo, **kwargs)
    compiled = compiled_radiance(model, env, wo, dtype=np.float64, **kwargs)
    np.testing.assert_allclose(compiled.value, numpy_path.value, rtol=1e-9, atol=1e-12)
