"""The BRDF protocol, checked generically on every registered model × its ``examples()``.

Collected at import time from :data:`brdfkit.brdf.MODELS`, so every new model is covered as soon
as it registers, together with its sum with a Lambertian lobe and its scaled version. Each case
checks shapes and signs of ``eval``/``pdf``, ``sample`` (unit directions, weight = f·|cos θi|/pdf,
χ² against ``pdf``), the claimed physics (reciprocity, energy conservation, isotropy), dtype
preservation and the torch backend with its gradients.
"""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import MODELS
from brdfkit.brdf.base import BRDF
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.checks import (
    check_energy,
    check_isotropy,
    check_nonnegativity,
    check_reciprocity,
    check_sampling,
)
from brdfkit.sampling import square_to_uniform_hemisphere, square_to_uniform_sphere

CHI2_SAMPLES = 200_000
"""Samples per view direction for the sampling checks (χ² and weight = f·|cos θi|/pdf)."""

SLOW_SAMPLERS = {"torrance_sparrow": 40_000}
"""Fewer samples for models whose sampler costs far more than ~1 µs a sample (Torrance–Sparrow
inverts the Gaussian's CDF by Newton iteration, ~50 µs a sample), to keep the suite quick."""


def _cases() -> list[tuple[str, str, BRDF]]:
    """(model name, test id, instance) for every example, a sum with a Lambertian and a scaling."""
    cases = []
    for name, cls in sorted(MODELS.items()):
        examples = cls.examples()
        cases += [(name, f"{name}[{i}]", m) for i, m in enumerate(examples)]
        middle = examples[len(examples) // 2]
        cases.append((name, f"lambertian+{name}", Lambertian(0.3) + middle))
        cases.append((name, f"0.5*{name}", 0.5 * middle))
    return cases


CASES = [pytest.param(brdf, id=case_id) for _, case_id, brdf in _cases()]
SAMPLING_CASES = [
    pytest.param(brdf, SLOW_SAMPLERS.get(name, CHI2_SAMPLES), id=case_id)
    for name, case_id, brdf in _cases()
]


def _directions(shape: tuple[int, ...], seed: int, sphere: bool) -> np.ndarray:
    u = np.random.default_rng(seed).random((*shape, 2))
    return square_to_uniform_sphere(u) if sphere else square_to_uniform_hemisphere(u)


@pytest.mark.parametrize("brdf", CASES)
def test_eval_and_pdf_shapes_signs_and_horizon(brdf: BRDF):
    wi = _directions((4, 8), seed=1, sphere=True)
    wo = _directions((4, 8), seed=2, sphere=True)
    f = brdf.eval(wi, wo)
    assert f.shape == (4, 8, brdf.channels)
    assert brdf.pdf(wi, wo).shape == (4, 8)
    # One view direction broadcast against a batch of light directions.
    assert brdf.eval(wi, wo[0, 0]).shape == (4, 8, brdf.channels)
    assert brdf.pdf(wi, wo[0, 0]).shape == (4, 8)
    result = check_nonnegativity(brdf, n=2048, seed=3)
    assert result.passed, result.detail


@pytest.mark.parametrize(("brdf", "samples"), SAMPLING_CASES)
def test_sampling_is_consistent_and_passes_chi2(brdf: BRDF, samples: int):
    result = check_sampling(brdf, theta_o=(0.4, 1.2), samples=samples, seed=4)
    assert result.passed, result.detail


@pytest.mark.parametrize("brdf", CASES)
def test_claimed_reciprocity(brdf: BRDF):
    if not brdf.reciprocal:
        pytest.skip("the model does not claim reciprocity")
    result = check_reciprocity(brdf, n=2048, seed=5, tolerance=1e-6)
    assert result.passed, result.detail


@pytest.mark.parametrize("brdf", CASES)
def test_claimed_energy_conservation(brdf: BRDF):
    if not brdf.energy_conserving:
        pytest.skip("the model does not claim energy conservation")
    # ρ(θo) ≤ 1 up to 3 Monte Carlo standard errors (and float64 rounding of exact albedos).
    result = check_energy(brdf, n_wo=6, samples=4096, seed=6, tolerance=1e-12, z=3.0)
    assert result.passed, result.detail


@pytest.mark.parametrize("brdf", CASES)
def test_claimed_isotropy(brdf: BRDF):
    if not brdf.isotropic:
        pytest.skip("the model does not claim isotropy")
    result = check_isotropy(brdf, n=2048, seed=7, tolerance=1e-6)
    assert result.passed, result.detail


@pytest.mark.parametrize("brdf", CASES)
def test_float32_stays_float32(brdf: BRDF):
    wi = _directions((64,), seed=8, sphere=False).astype(np.float32)
    wo = _directions((64,), seed=9, sphere=False).astype(np.float32)
    u = np.random.default_rng(10).random((64, 3)).astype(np.float32)
    assert brdf.eval(wi, wo).dtype == np.float32
    assert brdf.pdf(wi, wo).dtype == np.float32
    s = brdf.sample(wo, u)
    assert s.wi.dtype == s.weight.dtype == s.pdf.dtype == np.float32
    assert s.delta.dtype == np.bool_


@pytest.mark.parametrize("brdf", CASES)
def test_torch_matches_numpy_and_has_finite_gradients(brdf: BRDF):
    torch = pytest.importorskip("torch")
    wi = _directions((256,), seed=11, sphere=True)
    wo = _directions((256,), seed=12, sphere=False)
    u = np.random.default_rng(13).random((256, 3))
    wi_t = torch.tensor(wi, requires_grad=True)
    wo_t, u_t = torch.tensor(wo), torch.tensor(u)
    f_t = brdf.eval(wi_t, wo_t)
    assert isinstance(f_t, torch.Tensor) and f_t.dtype == torch.float64
    np.testing.assert_allclose(f_t.detach().numpy(), brdf.eval(wi, wo), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(
        brdf.pdf(wi_t, wo_t).detach().numpy(), brdf.pdf(wi, wo), rtol=1e-6, atol=1e-12
    )
    s_t, s = brdf.sample(wo_t, u_t), brdf.sample(wo, u)
    for name in ("wi", "weight", "pdf", "delta"):
        np.testing.assert_allclose(
            getattr(s_t, name).detach().numpy(),
            getattr(s, name),
            rtol=1e-6,
            atol=1e-12,
            err_msg=f"Sample.{name}",
        )
    # (+ 0·Σwi: a model constant in wi, such as the Lambertian, gives an output without a graph)
    (f_t.sum() + 0 * wi_t.sum()).backward()
    assert torch.all(torch.isfinite(wi_t.grad)), "non-finite gradient of eval w.r.t. wi"
