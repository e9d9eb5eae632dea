"""Kulla–Conty energy compensation of rough dielectrics, against quadrature and Heitz et al.'s
dielectric random walk."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from brdfkit.brdf import KullaContyDielectric, RoughDielectric
from brdfkit.brdf.kulla_conty_dielectric import (
    added_albedo,
    albedo_series,
    dielectric_albedo,
    split_node,
    split_table,
)
from brdfkit.brdf.random_walk import dielectric_random_walk_albedo
from brdfkit.errors import ParameterError

ALPHAS = (0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0)
THETAS = (0.0, 30.0, 55.0, 70.0, 80.0, 84.9)
ETAS = (1.1, 1.5, 2.5, 1 / 1.5)


def _direction(degrees: float, side: float) -> np.ndarray:
    theta = math.radians(degrees)
    return np.array([math.sin(theta), 0.0, side * math.cos(theta)])


def _compensated(model: KullaContyDielectric, wo: np.ndarray, nodes=(96, 64)) -> np.ndarray:
    """The model's flux albedo (R, T) from ``wo``: single scattering by quadrature plus the
    added lobes integrated from ``eval`` (importance mode)."""
    single = dielectric_albedo(model.alpha, model.eta, np.array([wo[2]]), nodes=nodes)[0]
    return single + added_albedo(model, wo)


def test_dielectric_albedo_from_mirrored_nodes_equals_the_full_quadrature(monkeypatch):
    """Half the azimuths (ωo in the xz-plane, an isotropic lobe): the same (R, T) to rounding,
    from outside and from inside, through total internal reflection."""
    import brdfkit.brdf.kulla_conty_dielectric as kcd

    mu = np.cos(np.radians(THETAS))
    mu = np.concatenate([mu, -mu])
    half = [dielectric_albedo(a, eta, mu) for a, eta in ((0.05, 1.5), (0.6, 1 / 1.5))]
    full_rule = kcd.visible_normal_quadrature
    monkeypatch.setattr(kcd, "visible_normal_quadrature", lambda nodes, mirror: full_rule(nodes))
    full = [dielectric_albedo(a, eta, mu) for a, eta in ((0.05, 1.5), (0.6, 1 / 1.5))]
    np.testing.assert_allclose(half, full, rtol=1e-13, atol=1e-16)


def _furnace_worst(etas, alphas, thetas) -> float:
    worst = 0.0
    for eta in etas:
        for alpha in alphas:
            model = KullaContyDielectric(alpha=alpha, eta=eta, mode="importance")
            for degrees in thetas:
                for side in (1.0, -1.0):
                    wo = _direction(degrees, side)
                    total = _compensated(model, wo, nodes=(144, 96)).sum()
                    worst = max(worst, abs(total - 1))
    return worst


def test_white_furnace_one_interface():
    """No absorption: R + T = 1 (flux), glass at α = 0.5, from both sides."""
    worst = _furnace_worst((1.5,), (0.5,), (0.0, 60.0, 84.9))
    assert worst < 0.005, worst


@pytest.mark.slow  # 4 η × 8 α × 6 θ × 2 sides: ~1 min CPU (8 min on 2 cores shared by 8)
def test_white_furnace_compensated_albedo_is_one():
    """R + T = 1 within 0.5 % for α ∈ [0.05, 1], θ < 85°, both sides, η ∈ {1.1, 1.5, 2.5,
    1/1.5}; single scattering by a finer quadrature than the model's, the added lobes
    integrated from eval (so the reciprocity-corrected normalisation is checked too)."""
    worst = _furnace_worst(ETAS, ALPHAS, THETAS)
    assert worst < 0.005, worst  # measured 3.1e-3 (η = 1.1, α = 1, θ = 0 inside)


def test_random_walk_first_order_is_the_single_scattering_lobe():
    """The walk's first order equals the quadrature of RoughDielectric (height-correlated
    Smith, importance mode), reflected and transmitted, from both sides; no path is lost."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for alpha, eta, degrees, side in [
            (0.3, 1.5, 0.0, 1.0),
            (1.0, 1.5, 60.0, -1.0),
            (0.6, 2.2, 75.0, 1.0),
            (0.6, 1 / 1.33, 30.0, -1.0),
        ]:
            wo = _direction(degrees, side)
            paths = 1 << 16
            walk = dielectric_random_walk_albedo(alpha, eta, wo, paths=paths, seed=3)
            r, t = dielectric_albedo(alpha, eta, np.array([wo[2]]))[0]
            for ours, theirs in ((r, walk.reflected_single), (t, walk.transmitted_single)):
                sigma = math.sqrt(ours * (1 - ours) / paths)
                assert abs(theirs - ours) < 4 * sigma + 1e-4
            assert walk.lost == 0.0
            assert walk.reflected + walk.transmitted == pytest.approx(1.0)


def _walk_comparison(alpha, eta, degrees, side, paths, seed, split="random_walk"):
    model = KullaContyDielectric(alpha=alpha, eta=eta, split=split, mode="importance")
    wo = _direction(degrees, side)
    ours = _compensated(model, wo)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        walk = dielectric_random_walk_albedo(alpha, eta, wo, paths=paths, seed=seed)
    return ours, np.array([walk.reflected, walk.transmitted]), walk.stderr


def test_glass_agrees_with_the_random_walk():
    """α = 1, η = 1.5, θ = 40° from outside: R (~2 %, mostly single scattering, its
    multiply scattered part is tabulated by the walk) and T each within 2 % of the walk."""
    ours, walk, _ = _walk_comparison(1.0, 1.5, 40.0, 1.0, paths=1 << 18, seed=11)
    np.testing.assert_allclose(ours, walk, rtol=0.02)


@pytest.mark.slow  # 4 η × 6 α × 5 θ × 2 sides, 2^17 paths each: ~40 s CPU
def test_compensated_albedo_agrees_with_the_random_walk_everywhere():
    """R and T each within 2 % of the walk (seeds independent of the table's) wherever the
    walk resolves 2 % (its standard error σ below 0.5 % of the value); where R or T is too
    small for 2¹⁷ paths to resolve 2 % (σ ≥ 0.5 %), within 2 % + 3σ. See
    ``benchmarks/kulla_conty_dielectric_accuracy.py`` for the measured worst cases."""
    worst_relative, worst_excess = 0.0, -1.0
    for e, eta in enumerate((1.33, 1.5, 2.2, 1 / 1.5)):
        for a, alpha in enumerate((0.05, 0.2, 0.4, 0.6, 0.8, 1.0)):
            for t, degrees in enumerate((0.0, 40.0, 60.0, 75.0, 84.0)):
                for side in (1.0, -1.0):
                    seed = 70_000 + 1000 * e + 100 * a + 10 * t + (side > 0)
                    ours, walk, sigma = _walk_comparison(alpha, eta, degrees, side, 1 << 17, seed)
                    for value, reference in zip(ours, walk, strict=True):
                        if sigma < 0.005 * reference:
                            worst_relative = max(worst_relative, abs(value / reference - 1))
                        else:
                            excess = abs(value - reference) - (0.02 * reference + 3 * sigma)
                            worst_excess = max(worst_excess, excess)
    assert worst_relative < 0.02, worst_relative
    assert worst_excess < 0, worst_excess


def test_generalised_reciprocity_with_the_added_lobes():
    """Radiance mode: f(ωi, ωo)/n_o² = f(ωo, ωi)/n_i², the added kernel included."""
    eta = 1.5
    model = KullaContyDielectric(alpha=0.7, eta=eta)
    rng = np.random.default_rng(2)
    v = rng.normal(size=(2, 500, 3))
    wi, wo = v / np.linalg.norm(v, axis=-1, keepdims=True)
    n2 = lambda w: np.where(w[:, 2:3] > 0, 1.0, eta * eta)  # noqa: E731
    forward, backward = model.eval(wi, wo) / n2(wo), model.eval(wo, wi) / n2(wi)
    assert np.all(forward > 0)
    np.testing.assert_allclose(forward, backward, rtol=1e-10)


@pytest.mark.parametrize("split", ["random_walk", "fresnel_average"])
@pytest.mark.parametrize("eta", [1.5, 1 / 1.33])
def test_the_added_lobes_carry_their_shares(split, eta):
    """∫ (f − f_ss)|cos θi| over each side is the share (a, b) the model assigns it (flux),
    and a + b = 1 − E(μo): the reciprocity correction keeps both sides exact."""
    model = KullaContyDielectric(alpha=0.9, eta=eta, split=split, mode="importance")
    for degrees, side in ((10.0, 1.0), (50.0, -1.0), (80.0, 1.0), (80.0, -1.0)):
        wo = _direction(degrees, side)
        a, b = (float(v[0, 0]) for v in model.shares(wo[None]))
        np.testing.assert_allclose(added_albedo(model, wo), [a, b], rtol=1e-3, atol=1e-7)
        assert a + b == pytest.approx(1 - float(model.E(wo[None])[0, 0]), abs=1e-12)
        assert a >= 0 and b >= 0


def test_published_split_overstates_reflection_from_outside():
    """Kulla & Conty's split by the average Fresnel sends F̄(1.5) ≈ 9 % of the multiply
    scattered light back; the walk reflects far less of it (α = 1, η = 1.5, θ = 0°)."""
    ours, walk, sigma = _walk_comparison(1.0, 1.5, 0.0, 1.0, 1 << 17, 5, "fresnel_average")
    assert ours[0] > walk[0] + 10 * sigma  # R too high …
    assert ours.sum() == pytest.approx(1.0, abs=0.005)  # … though R + T is right


def test_albedo_series_is_cached_and_smooth_glass_limits():
    coefficients = albedo_series(0.05, 1.5)
    assert albedo_series(0.05, 1.5) is coefficients
    model = KullaContyDielectric(alpha=0.05, eta=1.5)
    e = model.E(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]))[:, 0]
    assert e == pytest.approx([1.0, 1.0], abs=0.005)  # nearly smooth: little to add


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: KullaContyDielectric(eta=1.05), "eta must be"),
        (lambda: KullaContyDielectric(eta=3.0), "eta must be in"),
        (lambda: KullaContyDielectric(alpha=[0.2, 0.3, 0.4]), "alpha must be a scalar"),
        (lambda: KullaContyDielectric(alpha=0.001), "alpha must be in"),
        (lambda: KullaContyDielectric(split="kc"), "split must be one of"),
    ],
)
def test_bad_parameters_are_refused(factory, match):
    with pytest.raises(ParameterError, match=match):
        factory()


def test_single_lobe_is_the_rough_dielectric():
    model = KullaContyDielectric(alpha=0.4, eta=1.33)
    assert isinstance(model._single, RoughDielectric)
    assert model._single.masking == "smith_correlated"
    assert not model.reciprocal and model.transmits and model.energy_conserving


@pytest.mark.slow  # two walks of 2^17 paths: ~1-5 s on busy cores
def test_the_shipped_split_table_is_what_its_recipe_computes():
    """One (α, η, μ) node recomputed by the walk (same seeds) equals the shipped float32
    values (a few paths decided differently by another CPU's libm are allowed)."""
    node = split_node(6, 3, 9)
    np.testing.assert_allclose(split_table()[6, 3, 9], node, atol=5e-5)
    assert np.all(node >= 0) and np.sum(node) < 1


@pytest.mark.slow  # numba compiles eval, pdf and sample: ~1-3 min on two busy cores
def test_compiled_path_matches_numpy():
    from brdfkit.compiled import compile
    from brdfkit.geometry import spherical_to_cartesian

    model = KullaContyDielectric(alpha=0.4, eta=1.5)
    rng = np.random.default_rng(4)
    wi = spherical_to_cartesian(rng.random(500) * 3.1, rng.random(500) * 6)
    wo = spherical_to_cartesian(rng.random(500) * 3.1, rng.random(500) * 6)
    compiled = compile(model, dtype=np.float64)
    np.testing.assert_allclose(compiled.eval(wi, wo), model.eval(wi, wo), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(compiled.pdf(wi, wo), model.pdf(wi, wo), rtol=1e-9, atol=1e-12)
    u = rng.random((500, 3))
    ours, theirs = compiled.sample(wo, u), model.sample(wo, u)
    np.testing.assert_allclose(ours.wi, theirs.wi, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ours.weight, theirs.weight, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("side", [1.0, -1.0], ids=["outside", "inside"])
def test_one_sided_sampling_matches_its_density(side):
    """A one-sided render's view (:func:`~brdfkit.brdf.one_sided.one_sided_view`): χ² of
    sample_one_sided against pdf_one_sided on the upper hemisphere, weight = f·cos θi/pdf."""
    from brdfkit.brdf.one_sided import one_sided_view
    from brdfkit.checks import brdf_sampler, chi2_test

    model = KullaContyDielectric(alpha=0.7, eta=1.5)
    wo = _direction(50.0, side)
    view = one_sided_view(model)
    chi2_test(*brdf_sampler(view, wo), sample_dim=3, n_samples=40_000).assert_passed()
    s = view.sample(np.broadcast_to(wo, (2000, 3)), np.random.default_rng(1).random((2000, 3)))
    ok = s.pdf > 0
    assert np.all(s.wi[ok, 2] > 0) and np.all(s.weight[~ok] == 0)
    expected = model.eval(s.wi[ok], wo) * s.wi[ok, 2:3] / s.pdf[ok, None]
    np.testing.assert_allclose(s.weight[ok], expected, rtol=1e-10)


def test_shares_of_a_broadcast_direction_are_made_once_with_the_same_values():
    model = KullaContyDielectric(alpha=0.6, eta=1 / 1.5)
    for side in (1.0, -1.0):
        wo = np.broadcast_to(_direction(50.0, side), (300, 3))
        once = model.shares(wo)
        assert all(part.strides[0] == 0 for part in once)
        for part, full in zip(once, model.shares(np.array(wo)), strict=True):
            np.testing.assert_array_equal(part, full)
