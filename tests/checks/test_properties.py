"""Physics checks: each check passes on models known to have the property and fails on toy
models built to violate it; the report sets measurements against claims."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.special import erf

from brdfkit.brdf import microfacet
from brdfkit.brdf.base import Sample
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.checks import (
    PhysicsReport,
    check,
    check_energy,
    check_isotropy,
    check_nonnegativity,
    check_normalization,
    check_reciprocity,
    check_sampling,
    check_white_furnace,
)
from brdfkit.sampling import square_to_uniform_hemisphere


# --------------------------------------------------------------------------- toy models
@dataclass(frozen=True, eq=False)
class Skewed(Lambertian):
    """ρ/π · (1 + wi.x/2): non-reciprocal and anisotropic, yet inheriting Lambertian's claims."""

    def eval(self, wi, wo):
        return super().eval(wi, wo) * (1 + 0.5 * wi[..., :1])


@dataclass(frozen=True, eq=False)
class Negative(Lambertian):
    """ρ/π · (cos θi − 1/2): negative at grazing incidence."""

    def eval(self, wi, wo):
        return super().eval(wi, wo) * (wi[..., 2:] - 0.5)


@dataclass(frozen=True, eq=False)
class Leaky(Lambertian):
    """ρ/π everywhere, including below the horizon."""

    def eval(self, wi, wo):
        return np.broadcast_to(np.asarray(self.rho) / math.pi, (*wi.shape[:-1], 1))


@dataclass(frozen=True, eq=False)
class WrongPdf(Lambertian):
    """Reports a pdf 10 % too high in its samples."""

    def sample(self, wo, u):
        s = super().sample(wo, u)
        return Sample(s.wi, s.weight, 1.1 * s.pdf, s.delta)


@dataclass(frozen=True, eq=False)
class UniformlySampled(Lambertian):
    """Draws uniformly from the hemisphere but claims cosine-weighted draws (weights match the
    claimed pdf, so only the χ² test can tell)."""

    def sample(self, wo, u):
        s = super().sample(wo, u)
        wi = square_to_uniform_hemisphere(u[..., :2])
        pdf = wi[..., 2] / math.pi
        return Sample(wi, s.weight, pdf, s.delta)


@dataclass(frozen=True, eq=False)
class NoisyAlbedo(Lambertian):
    """A Lambertian whose albedo estimate is ``albedo`` with a given standard error."""

    stderr: float = 0.0

    def albedo_estimate(self, wo, samples=0, seed=0):
        mean, _ = super().albedo_estimate(wo)
        return mean, np.full_like(mean, self.stderr)


class Beckmann:
    """The Beckmann distribution and its Smith masking, in closed form (Walter et al. 2007)."""

    def __init__(self, alpha: float, exact_masking: bool = True):
        self.alpha, self.exact_masking = alpha, exact_masking

    def D(self, m):
        cos2 = np.clip(m[..., 2], 1e-300, None) ** 2
        tan2 = (1 - cos2) / cos2
        value = np.exp(-tan2 / self.alpha**2) / (math.pi * self.alpha**2 * cos2**2)
        return np.where(m[..., 2] > 0, value, 0.0)

    def G1(self, w, m):
        if not self.exact_masking:
            return np.ones(w.shape[:-1])
        cos = w[..., 2]
        tan = np.sqrt(np.maximum(1 - cos**2, 0)) / cos
        a = np.minimum(1 / (self.alpha * np.maximum(tan, 1e-300)), 1e100)
        lam = (erf(a) - 1) / 2 + np.exp(-a * a) / (2 * a * math.sqrt(math.pi))
        return np.where(np.sum(w * m, axis=-1) > 0, 1 / (1 + lam), 0.0)


# --------------------------------------------------------------------------- the checks
def test_lambertian_passes_everything_and_its_energy_is_its_albedo():
    report = check(Lambertian([0.9, 0.5, 0.25]))
    assert report.consistent
    assert all(r.passed for r in report.results)
    assert report["energy"].value == pytest.approx(0.9, abs=1e-15)
    assert report["reciprocity"].value == 0.0


def test_reciprocity_and_isotropy_measure_the_skew():
    reciprocity = check_reciprocity(Skewed(0.5), n=4096)
    isotropy = check_isotropy(Skewed(0.5), n=4096)
    assert not reciprocity.passed and not isotropy.passed
    assert reciprocity.contradicts_claim and isotropy.contradicts_claim
    # f(wi,wo) − f(wo,wi) ∝ (wi.x − wo.x)/2 and max f ∝ 1 + max(wi.x)/2, so the error is just
    # below 1/(1 + 1/2) = 2/3 for 4096 random pairs.
    assert 0.6 < reciprocity.value <= 2 / 3
    assert 0.6 < isotropy.value <= 2 / 3
    assert "CONTRADICTS" in reciprocity.verdict


def test_nonnegativity_finds_negative_values_and_light_below_the_horizon():
    negative = check_nonnegativity(Negative(0.5))
    assert not negative.passed
    assert -0.5 * 0.5 / math.pi <= negative.value < -0.49 * 0.5 / math.pi
    leaky = check_nonnegativity(Leaky(0.5))
    assert not leaky.passed and "below the horizon" in leaky.detail
    assert check_nonnegativity(Lambertian(0.5)).passed


def test_energy_fails_only_on_a_significant_violation():
    unphysical = check_energy(Lambertian(1.5, allow_unphysical=True))
    assert not unphysical.passed and unphysical.contradicts_claim
    assert unphysical.value == pytest.approx(1.5, abs=1e-15)
    assert check_energy(Lambertian(1.0)).passed
    # ρ̂ = 1.002 ± 0.001: within 3σ of 1, not a significant violation.
    assert check_energy(
        NoisyAlbedo(1.002, allow_unphysical=True, stderr=0.001), tolerance=0.0
    ).passed
    # ρ̂ = 1.01 ± 0.001 is ten standard errors above 1.
    assert not check_energy(
        NoisyAlbedo(1.01, allow_unphysical=True, stderr=0.001), tolerance=0.0
    ).passed


def test_sampling_catches_a_wrong_pdf_and_a_wrong_distribution():
    assert check_sampling(Lambertian(0.5)).passed
    wrong_pdf = check_sampling(WrongPdf(0.5))
    assert not wrong_pdf.passed and "Sample.pdf" in wrong_pdf.detail
    assert wrong_pdf.value == pytest.approx(1.1 - 1, rel=1e-9)  # 1.1p vs p: relative error 0.1
    wrong_distribution = check_sampling(UniformlySampled(0.5))
    assert not wrong_distribution.passed and "χ²" in wrong_distribution.detail


@pytest.mark.parametrize("alpha", [0.01, 0.1, 0.5, 1.0])
def test_beckmann_is_normalized_and_passes_the_white_furnace(alpha):
    distribution = Beckmann(alpha)
    normalization = check_normalization(distribution)
    assert normalization.passed, normalization.detail
    assert normalization.value < 1e-6
    furnace = check_white_furnace(distribution)
    assert furnace.passed, furnace.detail


@pytest.mark.parametrize(
    "distribution",
    [
        microfacet.GGX(0.1),
        microfacet.GGX(0.02, 0.4),
        microfacet.GGX([0.1, 0.3, 0.6]),
        microfacet.Beckmann(0.7, 0.2),
    ],
    ids=repr,
)
def test_library_distributions_are_normalized_and_pass_the_white_furnace(distribution):
    normalization = check_normalization(distribution)
    assert normalization.passed, normalization.detail
    furnace = check_white_furnace(distribution)
    assert furnace.passed, furnace.detail


def test_hemisphere_nodes_are_shared_read_only_and_integrate_exactly():
    # Every microfacet check integrates over the same cached nodes: an integrand that wrote
    # into them would corrupt every later check, so they are read-only.
    from brdfkit.checks.properties import _hemisphere_integral, _hemisphere_nodes

    m, theta_weight = _hemisphere_nodes()
    assert _hemisphere_nodes()[0] is m
    with pytest.raises(ValueError):
        m[0, 0] = 0.0
    with pytest.raises(ValueError):
        theta_weight[0] = 0.0
    assert _hemisphere_integral(lambda m: m[:, 2])[0] == pytest.approx(math.pi, rel=1e-12)
    assert _hemisphere_integral(lambda m: m[:, 0] ** 2)[0] == pytest.approx(
        2 * math.pi / 3, rel=1e-12
    )


def test_white_furnace_fails_without_masking():
    # With G1 = 1 the projected area seen from θo exceeds cos θo (Heitz 2014, §4).
    furnace = check_white_furnace(Beckmann(0.5, exact_masking=False))
    assert not furnace.passed and furnace.value > 0.01


def test_report_states_claims_and_serializes():
    report = check(Skewed(0.5))
    assert isinstance(report, PhysicsReport)
    assert not report.consistent
    assert {r.name for r in report.contradictions} >= {"reciprocity", "isotropy"}
    data = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    assert data["consistent"] is False
    assert data["claims"]["reciprocal"] is True
    names = [c["name"] for c in data["checks"]]
    assert names == ["non-negativity", "reciprocity", "energy", "isotropy", "sampling"]
    with pytest.raises(KeyError, match="no check named 'colour'"):
        report["colour"]


def test_table_lists_every_check_with_its_verdict():
    from rich.console import Console

    console = Console(record=True, width=200)
    console.print(check(Lambertian(0.5)).to_table())
    text = console.export_text()
    for verdict in (
        "reciprocal (as claimed)",
        "energy-conserving (as claimed)",
        "isotropic (as claimed)",
        "non-negative (as claimed)",
    ):
        assert verdict in text


def test_original_phong_is_reported_not_reciprocal_as_it_claims():
    from brdfkit.brdf import MODELS

    if "phong" not in MODELS:
        pytest.skip("the original Phong model is not registered yet")
    report = check(MODELS["phong"](n=20))
    assert report["reciprocity"].verdict == "not reciprocal (as it claims)"
    assert report.consistent


@pytest.mark.parametrize("name", ["ggx", "torrance_sparrow", "rough_plastic"])
def test_check_runs_the_microfacet_checks_on_the_models_distribution(name):
    # the models keep their distribution in ``ndf``; check() once looked for ``distribution``
    # (a string on some models) and skipped both checks on every microfacet model
    from brdfkit.brdf import MODELS

    report = check(MODELS[name]())
    names = [r.name for r in report.results]
    assert "normalization" in names and "white furnace" in names
    assert report["normalization"].passed and report["white furnace"].passed


# --------------------------------------------------------------------------- transmission
def test_albedo_estimate_both_hemispheres_adds_the_transmittance():
    from brdfkit.brdf import RoughDielectric, SmoothDielectric
    from brdfkit.fresnel import fresnel_dielectric

    wo = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    f = fresnel_dielectric(wo[:, 2], 1.5)[:, None]
    for mode, scale in (("radiance", 1 / 1.5**2), ("importance", 1.0)):
        upper, _ = SmoothDielectric(1.5, mode=mode).albedo_estimate(wo)
        both, _ = SmoothDielectric(1.5, mode=mode).albedo_estimate(wo, hemisphere="both")
        np.testing.assert_allclose(upper, f, rtol=1e-14)
        np.testing.assert_allclose(both, f + (1 - f) * scale, rtol=1e-14)
    # A nearly smooth rough dielectric in importance mode transmits almost all of 1 − F.
    rough = RoughDielectric(alpha=0.01, mode="importance")
    upper, _ = rough.albedo_estimate(wo, samples=1 << 14)
    both, stderr = rough.albedo_estimate(wo, samples=1 << 14, hemisphere="both")
    np.testing.assert_allclose(upper, f, rtol=2e-2)
    assert np.all(np.abs(both - 1) < 3e-3 + 4 * stderr)
    with pytest.raises(ValueError, match="hemisphere must be one of"):
        rough.albedo_estimate(wo, hemisphere="lower")


def test_energy_of_a_bsdf_is_checked_on_reflectance_plus_transmittance():
    from brdfkit.brdf import RoughDielectric

    glass = RoughDielectric(alpha=0.3)  # radiance mode: checked in importance (flux) mode
    result = check_energy(glass, n_wo=4, samples=4096)
    assert result.passed and 0.9 < result.value <= 1.0 + 1e-3
    assert "transmittance" in result.detail
    # 1.2 × glass reflects only ~6 %, but its total is ~1.2: the check must see that.
    brighter = 1.2 * glass
    assert float(np.max(brighter.albedo(np.array([[0.0, 0.0, 1.0]])))) < 0.1
    assert not check_energy(brighter, n_wo=4, samples=4096).passed
