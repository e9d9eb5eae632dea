"""The Hosek–Wilkie sun and sky (brdfkit.light.sunsky): Mitsuba 3's ``sunsky`` emitter as the oracle
of its radiance, and the Light protocol (sample value = L/pdf, χ² against pdf, unbiased
irradiance)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.checks import chi2_test
from brdfkit.errors import ParameterError
from brdfkit.light import SunSky

ELEVATIONS = (10.0, 35.0, 70.0)  # degrees
TURBIDITIES = (2.0, 6.0)


def _sun(elevation_deg: float, azimuth: float = 0.9) -> np.ndarray:
    e = math.radians(elevation_deg)
    return np.array([math.cos(e) * math.cos(azimuth), math.cos(e) * math.sin(azimuth), math.sin(e)])


def _dome(n: int, seed: int) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] = np.abs(d[:, 2])
    return d


def _mitsuba_radiance(mi, emitter, directions: np.ndarray) -> np.ndarray:
    out = []
    for v in directions:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, -v))  # Mitsuba's si.wi points away from the emitter
        out.append(np.array(emitter.eval(si)))
    return np.array(out)


@pytest.mark.oracle
@pytest.mark.parametrize("turbidity", TURBIDITIES)
@pytest.mark.parametrize("elevation", ELEVATIONS)
def test_sky_dome_and_sun_match_mitsuba_sunsky(elevation, turbidity):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    sun = _sun(elevation)
    spec = {"type": "sunsky", "sun_direction": list(map(float, sun)), "turbidity": turbidity}
    sky = mi.load_dict({**spec, "sun_scale": 0.0, "albedo": 0.2})
    ours = SunSky(sun_direction=sun, turbidity=turbidity, albedo=0.2, sun_scale=0.0)
    dome = np.concatenate([_dome(1500, 1), sun + 0.02 * _dome(100, 2)])  # and near the sun
    dome /= np.linalg.norm(dome, axis=1, keepdims=True)
    reference = _mitsuba_radiance(mi, sky, dome)
    mine = ours.incident_radiance(np.zeros(3), dome)
    assert np.all(reference > 0)
    np.testing.assert_allclose(mine, reference, rtol=1e-2)
    assert np.max(np.abs(mine / reference - 1)) < 1e-4  # in fact: the same formula and data
    # The solar disk (centre and inside the rim), sky switched off.
    only_sun = mi.load_dict({**spec, "sky_scale": 0.0})
    ours_sun = SunSky(sun_direction=sun, turbidity=turbidity, sky_scale=0.0)
    frame_u = np.cross(sun, [0.0, 0.0, 1.0])
    frame_u /= np.linalg.norm(frame_u)
    inside = [sun, np.cos(0.004) * sun + np.sin(0.004) * frame_u]
    np.testing.assert_allclose(
        ours_sun.incident_radiance(np.zeros(3), np.array(inside)),
        _mitsuba_radiance(mi, only_sun, np.array(inside)),
        rtol=1e-2,
    )
    outside = np.cos(0.006) * sun + np.sin(0.006) * frame_u  # beyond the 0.268° rim
    assert np.all(ours_sun.incident_radiance(np.zeros(3), outside) == 0)


def test_sample_value_is_radiance_over_pdf():
    light = SunSky(sun_direction=_sun(30.0), turbidity=3.0)
    points = np.zeros((4000, 3))
    s = light.sample(points, np.random.default_rng(0).random((4000, 2)))
    assert np.all(s.pdf > 0) and np.all(s.wi[:, 2] >= 0)
    np.testing.assert_allclose(light.pdf(points, s.wi), s.pdf, rtol=1e-10)
    np.testing.assert_allclose(
        s.value * s.pdf[:, None], light.incident_radiance(points, s.wi), rtol=1e-10
    )
    in_sun = np.sum(s.wi @ light.sun_direction >= light._cos_sun)
    assert 0.02 < in_sun / 4000 < 0.98  # both strategies are used


@pytest.mark.slow
def test_sky_sampler_passes_chi2():
    """The sky's tabulated sampler against its pdf (the sun, a 0.27° cone, is below the χ²
    histogram's resolution; its share is checked by the irradiance test below)."""
    light = SunSky(sun_direction=_sun(50.0), turbidity=2.0, sun_scale=0.0)
    result = chi2_test(
        lambda u: light.sample(np.zeros((*u.shape[:-1], 3)), u).wi,
        lambda w: light.pdf(np.zeros((*w.shape[:-1], 3)), w),
        sphere=True,
    )
    assert result.passed, result


def test_irradiance_estimate_is_unbiased():
    """E on an upward plane: light-sampled Monte Carlo against quadrature of the sky plus the
    sun's L·Ω·cos θsun."""
    light = SunSky(sun_direction=_sun(40.0), turbidity=3.0)
    n = 1 << 17
    s = light.sample(np.zeros((n, 3)), np.random.default_rng(1).random((n, 2)))
    terms = s.value * s.wi[:, 2:3]
    estimate, error = terms.mean(axis=0), terms.std(axis=0) / math.sqrt(n)
    x, w = np.polynomial.legendre.leggauss(256)
    mu, w_mu = 0.5 * (x + 1), 0.5 * w
    phi = 2 * np.pi * (np.arange(512) + 0.5) / 512
    m, p = np.meshgrid(mu, phi, indexing="ij")
    r = np.sqrt(1 - m * m)
    d = np.stack([r * np.cos(p), r * np.sin(p), m], axis=-1)
    weights = np.outer(w_mu, np.full(512, 2 * np.pi / 512)) * m
    sky = np.einsum("ijc,ij->c", light.sky_radiance(d), weights)
    solid_angle = 2 * math.pi * (1 - light._cos_sun)
    sun = light._sun * solid_angle * light.sun_direction[2]
    np.testing.assert_allclose(estimate, sky + sun, rtol=5 * np.max(error / estimate))


def test_parameters_are_checked():
    with pytest.raises(ParameterError, match="turbidity"):
        SunSky(turbidity=12.0)
    with pytest.raises(ParameterError, match="horizon"):
        SunSky(sun_direction=(1.0, 0.0, -0.1))
    with pytest.raises(ParameterError, match="albedo"):
        SunSky(albedo=1.5)


def test_torch_matches_numpy():
    torch = pytest.importorskip("torch")
    light = SunSky(sun_direction=_sun(25.0), turbidity=5.0)
    points = np.zeros((512, 3))
    u = np.random.default_rng(3).random((512, 2))
    s, s_t = light.sample(points, u), light.sample(torch.tensor(points), torch.tensor(u))
    assert isinstance(s_t.value, torch.Tensor)
    np.testing.assert_allclose(s_t.wi.numpy(), s.wi, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(s_t.value.numpy(), s.value, rtol=1e-9)
    np.testing.assert_allclose(s_t.pdf.numpy(), s.pdf, rtol=1e-9)


def test_light_spec():
    from brdfkit.errors import SpecError
    from brdfkit.light import parse_light

    light = parse_light("sunsky:0,0.6,0.8:4")
    assert isinstance(light, SunSky) and light.turbidity == 4.0
    np.testing.assert_allclose(light.sun_direction, [0, 0.6, 0.8])
    with pytest.raises(SpecError, match="sunsky"):
        parse_light("sunsky:0,1")
    with pytest.raises(ParameterError, match="turbidity"):
        parse_light("sunsky:0,0.6,0.8:11")
