"""Mitsuba 3 (``scalar_rgb``) as an oracle for the diffuse, microfacet and smooth models, each
built by the exporter (:func:`brdfkit.interop.to_mitsuba_dict`).

Mitsuba's ``si.wi`` is our ``wo`` (towards the viewer) and its ``bsdf.eval(ctx, si, v)`` is
f·|cos θ_v|; Mitsuba evaluates separable Smith masking and, for Beckmann, Walter's rational G1,
so the models are built with ``masking="smith_separable"`` and ``approximate_g1=True``.
Mitsuba computes in float32: agreement is to 1e-4 relative.
"""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import (
    Lambertian,
    RoughConductor,
    RoughDielectric,
    SmoothConductor,
    SmoothDielectric,
)
from brdfkit.fresnel import conductor
from brdfkit.interop import to_mitsuba_dict

mi = pytest.importorskip("mitsuba")
pytestmark = pytest.mark.oracle

RTOL = 1e-4
ATOL = 1e-6  # float32 noise on values near 0 (Mitsuba's own rounding)
N_PAIRS = 200


@pytest.fixture(scope="module", autouse=True)
def _variant():
    mi.set_variant("scalar_rgb")


def _assert_close(actual, desired, **tolerances) -> None:
    """``assert_allclose`` with grey values broadcast against Mitsuba's RGB triples."""
    actual, desired = np.broadcast_arrays(np.asarray(actual), np.asarray(desired))
    np.testing.assert_allclose(actual, desired, **tolerances)


def _interaction(wo: np.ndarray):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*map(float, wo))
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    return si


def _mitsuba_eval_pdf(bsdf, wi: np.ndarray, wo: np.ndarray, ctx=None) -> tuple[np.ndarray, float]:
    """Mitsuba's f (its eval divided by |cos θi|) and pdf for our (wi, wo)."""
    ctx = mi.BSDFContext() if ctx is None else ctx
    si = _interaction(wo)
    v = mi.Vector3f(*map(float, wi))
    return np.array(bsdf.eval(ctx, si, v)) / abs(wi[2]), float(bsdf.pdf(ctx, si, v))


def _upper(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


def test_diffuse():
    ours = Lambertian([0.2, 0.5, 0.8])
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    for wi, wo in zip(_upper(N_PAIRS, 1), _upper(N_PAIRS, 2), strict=True):
        value, _ = _mitsuba_eval_pdf(bsdf, wi, wo)
        _assert_close(ours.eval(wi, wo), value, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("name", ["Au", "Cu", "Ag"])
def test_conductor_presets_are_mitsubas(name):
    params = mi.traverse(mi.load_dict({"type": "roughconductor", "material": name}))
    eta, k = conductor(name)
    _assert_close(eta, np.array(params["eta.value"]), rtol=1e-6)
    _assert_close(k, np.array(params["k.value"]), rtol=1e-6)


ROUGH_CONDUCTORS = [
    {"alpha": 0.3, "material": "Au"},
    {"alpha": 0.25, "distribution": "beckmann", "material": "Cu"},
    {"alpha_u": 0.1, "alpha_v": 0.5, "material": "Au"},
    {"alpha_u": 0.4, "alpha_v": 0.15, "distribution": "beckmann", "material": "Ag"},
    {"alpha": 0.6, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1]},
]


@pytest.mark.parametrize("kwargs", ROUGH_CONDUCTORS, ids=[str(k) for k in ROUGH_CONDUCTORS])
def test_roughconductor(kwargs):
    ours = RoughConductor(**kwargs, masking="smith_separable", approximate_g1=True)
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    nonzero = 0
    for wi, wo in zip(_upper(N_PAIRS, 3), _upper(N_PAIRS, 4), strict=True):
        value, pdf = _mitsuba_eval_pdf(bsdf, wi, wo)
        _assert_close(ours.eval(wi, wo), value, rtol=RTOL, atol=ATOL)
        _assert_close(ours.pdf(wi, wo), pdf, rtol=RTOL, atol=ATOL)
        nonzero += bool(np.any(value > ATOL))
    assert nonzero > N_PAIRS // 3


ROUGH_DIELECTRICS = [
    {"alpha": 0.3, "eta": 1.5},
    {"alpha": 0.2, "eta": 1.33, "distribution": "beckmann"},
    {"alpha_u": 0.1, "alpha_v": 0.4, "eta": 2.0 / 1.2},
]


@pytest.mark.parametrize("mode", ["radiance", "importance"])
@pytest.mark.parametrize("kwargs", ROUGH_DIELECTRICS, ids=[str(k) for k in ROUGH_DIELECTRICS])
def test_roughdielectric(kwargs, mode):
    """Reflection and transmission, from both sides, at pairs drawn by our own sampler."""
    ours = RoughDielectric(**kwargs, approximate_g1=True, mode=mode)
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    transport = mi.TransportMode.Radiance if mode == "radiance" else mi.TransportMode.Importance
    ctx = mi.BSDFContext(transport)
    wo = _upper(N_PAIRS, 5)
    wo[N_PAIRS // 2 :, 2] *= -1  # half the viewers inside the dielectric
    s = ours.sample(wo, np.random.default_rng(6).random((N_PAIRS, 3)))
    counts = {"reflection": 0, "transmission": 0}
    for wi_k, wo_k, pdf_k in zip(s.wi, wo, s.pdf, strict=True):
        if pdf_k == 0:
            continue
        value, pdf = _mitsuba_eval_pdf(bsdf, wi_k, wo_k, ctx)
        _assert_close(ours.eval(wi_k, wo_k), value, rtol=RTOL, atol=ATOL)
        _assert_close(ours.pdf(wi_k, wo_k), pdf, rtol=RTOL, atol=ATOL)
        counts["reflection" if wi_k[2] * wo_k[2] > 0 else "transmission"] += 1
    assert counts["reflection"] > 10 and counts["transmission"] > 50


def _mitsuba_sample(bsdf, wo: np.ndarray, u0: float, component: int | None = None, mode=None):
    ctx = mi.BSDFContext() if mode is None else mi.BSDFContext(mode)
    if component is not None:
        ctx.component = component
    bs, weight = bsdf.sample(ctx, _interaction(wo), u0, mi.Point2f(0.5, 0.5))
    return np.array(bs.wo), np.array(weight)


@pytest.mark.parametrize(
    "kwargs",
    [{"material": "Au"}, {"material": "Al"}, {"eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1]}],
)
def test_smooth_conductor_fresnel(kwargs):
    ours = SmoothConductor(**kwargs)
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    wo = _upper(N_PAIRS, 7)
    s = ours.sample(wo, np.full((N_PAIRS, 2), 0.5))
    assert np.all(s.delta)
    for k in range(N_PAIRS):
        direction, weight = _mitsuba_sample(bsdf, wo[k], 0.5)
        _assert_close(s.wi[k], direction, atol=1e-6)
        _assert_close(s.weight[k], weight, rtol=RTOL, atol=ATOL)
    _assert_close(ours.albedo(wo), s.weight, rtol=0, atol=0)


@pytest.mark.parametrize("mode", ["radiance", "importance"])
@pytest.mark.parametrize(("int_ior", "ext_ior"), [(1.5, 1.0), (1.33, 1.0), (2.4, 1.5)])
def test_smooth_dielectric_fresnel(int_ior, ext_ior, mode):
    """F and 1 − F (with the η² radiance scaling) from Mitsuba's single-component sample
    weights; the lobe choice and the combined weights for the same uniform."""
    ours = SmoothDielectric(eta=int_ior / ext_ior, mode=mode)
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    transport = mi.TransportMode.Radiance if mode == "radiance" else mi.TransportMode.Importance
    wo = _upper(N_PAIRS, 8)
    wo[N_PAIRS // 2 :, 2] *= -1
    fresnel = ours.albedo(wo)[..., 0]
    u_reflect = np.stack([0.999 * fresnel, np.zeros(N_PAIRS)], axis=-1)
    u_refract = np.stack([np.minimum(fresnel + 1e-3, 0.9999), np.zeros(N_PAIRS)], axis=-1)
    s_reflect, s_refract = ours.sample(wo, u_reflect), ours.sample(wo, u_refract)
    for k in range(N_PAIRS):
        _, reflectance = _mitsuba_sample(bsdf, wo[k], 0.5, component=0, mode=transport)
        _assert_close(fresnel[k], reflectance[0], rtol=RTOL, atol=ATOL)
        _, transmittance = _mitsuba_sample(bsdf, wo[k], 0.5, component=1, mode=transport)
        _assert_close(
            (1 - fresnel[k]) * s_refract.weight[k, 0], transmittance[0], rtol=RTOL, atol=ATOL
        )
        for ours_sample, u0 in ((s_reflect, u_reflect[k, 0]), (s_refract, u_refract[k, 0])):
            direction, weight = _mitsuba_sample(bsdf, wo[k], float(u0), mode=transport)
            _assert_close(ours_sample.wi[k], direction, atol=1e-5)
            _assert_close(ours_sample.weight[k], weight, rtol=RTOL, atol=ATOL)
