"""The Mitsuba 3 exporter against Mitsuba 3 itself (``scalar_rgb``): each exported ``<bsdf>``
document loads and evaluates as brdfkit does, and what has no counterpart is refused by name.

Mitsuba's ``si.wi`` is brdfkit's ``wo``; its ``eval`` is f·|cos θ| of brdfkit's ``wi``.
"""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import (
    Lambertian,
    Phong,
    Principled,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    SmoothPlastic,
)
from brdfkit.errors import ParameterError
from brdfkit.interop import (
    mitsuba_approximations,
    to_mitsuba_dict,
    to_mitsuba_xml,
    write_mitsuba_xml,
)

N_PAIRS = 300

MODELS = {
    "lambertian": Lambertian([0.2, 0.5, 0.8]),
    "ggx_anisotropic_gold": RoughConductor(
        alpha_u=0.1, alpha_v=0.4, material="Au", masking="smith_separable"
    ),
    "beckmann_copper": RoughConductor(
        alpha=0.25,
        distribution="beckmann",
        material="Cu",
        masking="smith_separable",
        approximate_g1=True,
    ),
    "rough_dielectric": RoughDielectric(alpha=0.3, eta=1.5),
    "plastic": SmoothPlastic(diffuse_reflectance=[0.8, 0.3, 0.1], eta=1.5, internal="mitsuba"),
    "roughplastic_nonlinear": RoughPlastic(
        alpha=0.3,
        distribution="ggx",
        diffuse_reflectance=0.9,
        nonlinear=True,
        internal="mitsuba",
    ),
    "principled": Principled(
        base_color=[0.5, 0.8, 0.3],
        metallic=0.4,
        roughness=0.4,
        anisotropic=0.8,
        specular=0.8,
        specular_tint=0.6,
        clearcoat=0.5,
    ),
    "dichromatic_sum": Lambertian([0.5, 0.1, 0.1])
    + 2.0 * RoughConductor(alpha=0.1, eta=1.5, k=0.0, masking="smith_separable")
    + Lambertian(0.2),
}


@pytest.fixture(scope="module")
def mi():
    mitsuba = pytest.importorskip("mitsuba")
    mitsuba.set_variant("scalar_rgb")
    return mitsuba


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


def _mitsuba_f(mi, bsdf, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Mitsuba's f (its eval over |cos θ| of brdfkit's wi), one pair at a time."""
    ctx, values = mi.BSDFContext(), []
    for light, view in zip(wi, wo, strict=True):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, view))
        si.sh_frame = mi.Frame3f(mi.Normal3f(0, 0, 1))
        value = np.array(bsdf.eval(ctx, si, mi.Vector3f(*map(float, light))))
        values.append(value / abs(light[2]))
    return np.array(values)


def _p99_relative_error(brdf, theirs: np.ndarray, wi, wo) -> float:
    ours = np.broadcast_to(brdf.eval(wi, wo), theirs.shape)
    errors = np.abs(ours - theirs) / np.maximum(np.abs(theirs), 1e-6 * np.abs(theirs).max())
    return float(np.percentile(errors, 99))


@pytest.mark.oracle
@pytest.mark.parametrize("name", list(MODELS))
def test_exported_xml_evaluates_as_brdfkit(mi, name):
    brdf = MODELS[name]
    bsdf = mi.load_string(to_mitsuba_xml(brdf))
    wi, wo = _directions(N_PAIRS, 1), _directions(N_PAIRS, 2)
    if brdf.transmits:
        wi[::2, 2] *= -1  # half the pairs through the interface
    theirs = _mitsuba_f(mi, bsdf, wi, wo)
    assert np.count_nonzero(theirs.max(axis=-1) > 1e-6) > N_PAIRS // 3
    assert _p99_relative_error(brdf, theirs, wi, wo) < 1e-3


@pytest.mark.oracle
def test_written_file_loads_with_load_file(mi, tmp_path):
    brdf = MODELS["dichromatic_sum"]
    path = write_mitsuba_xml(brdf, tmp_path / "material.xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["material.xml"]
    bsdf = mi.load_file(str(path))
    wi, wo = _directions(50, 3), _directions(50, 4)
    assert _p99_relative_error(brdf, _mitsuba_f(mi, bsdf, wi, wo), wi, wo) < 1e-3


def test_a_model_without_counterpart_is_refused_by_name():
    with pytest.raises(ParameterError, match=r"Phong has no Mitsuba 3 counterpart.*RGL"):
        to_mitsuba_dict(Phong())


def test_inexact_options_are_refused_unless_approximating():
    correlated = RoughConductor(alpha=0.3, material="Au")  # height-correlated masking
    with pytest.raises(ParameterError, match="masking='smith_correlated'"):
        to_mitsuba_dict(correlated)
    spec = to_mitsuba_dict(correlated, approximate=True)
    assert spec["type"] == "roughconductor" and spec["alpha"] == 0.3
    assert mitsuba_approximations(correlated) == [
        "RoughConductor masking='smith_correlated': Mitsuba evaluates 'smith_separable' (G1·G1)"
    ]
    assert mitsuba_approximations(MODELS["plastic"]) == []


def test_sums_beyond_mitsubas_reflectance_bound_are_refused():
    with pytest.raises(ParameterError, match=r"add to 1\.4 > 1"):
        to_mitsuba_dict(Lambertian([0.9, 0.1, 0.1]) + Lambertian([0.1, 0.5, 0.1]))


def test_spatially_varying_parameters_are_refused():
    with pytest.raises(ParameterError, match=r"rho of shape \(2, 3\)"):
        to_mitsuba_dict(Lambertian(np.full((2, 3), 0.5)))
