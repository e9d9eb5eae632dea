"""The reflection equation: white-out, closed forms, and agreement of all estimators."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Lambertian
from brdfkit.light import DirectionalLight, EnvironmentMap, PointLight, SphereLight, UniformSky
from brdfkit.render import directional_albedo, hemispherical_reflectance, reflected_radiance


def _directions(n, seed=0, upper=True):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    if upper:
        v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.parametrize("method", ["quadrature", "brdf", "light", "mis"])
def test_white_out_lambertian_under_uniform_sky(method):
    """ρ·L for every view when the normal faces the sky (lectures: "white-out")."""
    rho, sky = 0.7, 2.5
    wo = _directions(20, 1)
    e = reflected_radiance(Lambertian(rho), UniformSky(sky), wo, method=method, samples=2048)
    tol = 1e-9 if method in ("quadrature", "brdf") else 4 * float(e.stderr.max()) + 1e-12
    np.testing.assert_allclose(e.value, rho * sky, atol=tol)


def test_white_out_for_tilted_normals_with_a_full_sphere_sky():
    """A uniform environment (all directions) gives ρL for any normal and view."""
    env = EnvironmentMap(np.full((8, 16, 3), 1.5))
    normals = _directions(10, 2, upper=False)
    wo = normals + 0.3 * _directions(10, 3, upper=False)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    q = reflected_radiance(Lambertian(0.4), env, wo, normal=normals, method="quadrature")
    m = reflected_radiance(Lambertian(0.4), env, wo, normal=normals, method="mis", samples=4096)
    np.testing.assert_allclose(q.value, 0.6, rtol=1e-6)
    assert np.all(np.abs(m.value - 0.6) <= 4 * m.stderr + 1e-9)


def test_directional_light_is_exact_closed_form():
    d = np.array([0.3, -0.2, 0.9])
    d /= np.linalg.norm(d)
    normals = _directions(50, 4)
    e = reflected_radiance(
        Lambertian([0.8, 0.5, 0.2]), DirectionalLight(d, 3.0), normals, normal=normals
    )
    expected = np.array([0.8, 0.5, 0.2]) / math.pi * 3.0 * np.clip(normals @ d, 0, None)[:, None]
    np.testing.assert_allclose(e.value, expected, rtol=1e-12)
    assert np.all(e.stderr == 0)


def test_point_light_inverse_square_on_a_plane():
    light = PointLight(position=(0, 0, 2.0), intensity=10.0)
    x = np.linspace(-3, 3, 13)
    points = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=-1)
    wo = np.tile([0, 0, 1.0], (13, 1))
    e = reflected_radiance(Lambertian(1.0), light, wo, point=points)
    r2 = x**2 + 4
    expected = 10.0 / r2 * (2 / np.sqrt(r2)) / math.pi
    np.testing.assert_allclose(e.value[:, 0], expected, rtol=1e-12)


def test_sphere_light_estimators_agree_with_closed_form():
    light = SphereLight(center=(0, 0, 4.0), radius=1.0, radiance=3.0)
    wo = np.array([[0, 0, 1.0]])
    exact = 0.5 / math.pi * math.pi * 3.0 * (1 / 16)  # ρ/π · πL sin²α
    for method in ("light", "mis"):
        e = reflected_radiance(Lambertian(0.5), light, wo, method=method, samples=20000)
        assert abs(float(e.value[0, 0]) - exact) <= 4 * float(e.stderr[0, 0]) + 1e-12
    q = reflected_radiance(
        Lambertian(0.5), light, wo, method="quadrature", theta_steps=256, phi_steps=64
    )
    assert abs(float(q.value[0, 0]) - exact) / exact < 1e-2


def test_directional_and_hemispherical_reflectance_of_lambertian():
    wo = _directions(5, 5)
    np.testing.assert_allclose(
        directional_albedo(Lambertian(0.3), wo, method="quadrature").value, 0.3
    )
    np.testing.assert_allclose(
        hemispherical_reflectance(Lambertian([0.2, 0.9]), method="quadrature"), [0.2, 0.9]
    )


def test_bad_arguments():
    with pytest.raises(ValueError, match="method must be one of"):
        reflected_radiance(Lambertian(), UniformSky(), np.array([0, 0, 1.0]), method="magic")
    with pytest.raises(ValueError, match="light must be a Light"):
        reflected_radiance(Lambertian(), [], np.array([0, 0, 1.0]))
    with pytest.raises(ValueError, match="samples must be >= 1"):
        reflected_radiance(Lambertian(), UniformSky(), np.array([0, 0, 1.0]), samples=0)
    with pytest.raises(ValueError, match="wo must have a last axis"):
        reflected_radiance(Lambertian(), UniformSky(), np.array([0, 1.0]))


def test_torch_backend_and_gradients_through_the_albedo():
    torch = pytest.importorskip("torch")
    rho = torch.tensor([0.5], dtype=torch.float64, requires_grad=True)
    wo = torch.tensor([[0.0, 0.0, 1.0]], dtype=torch.float64)
    e = reflected_radiance(Lambertian(rho), UniformSky(2.0), wo, method="quadrature")
    assert isinstance(e.value, torch.Tensor)
    e.value.sum().backward()
    assert abs(float(rho.grad) - 2.0) < 1e-9


def _glossy_queries(n=32):
    rng = np.random.default_rng(5)
    normals = _directions(n, 6)
    wo = normals + 0.5 * rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    return np.where((np.sum(wo * normals, -1) > 0.1)[:, None], wo, normals), normals


def _estimate(env, brdf, method, samples, heuristic="power", seed=0):
    """One estimate of each of the 32 glossy queries."""
    wo, normals = _glossy_queries()
    return reflected_radiance(
        brdf,
        env,
        wo,
        normal=normals,
        method=method,
        samples=samples,
        heuristic=heuristic,
        seed=seed,
    )


def _strategy_variances(env, brdf, samples=2048, heuristic="power"):
    return {
        method: float(np.mean(_estimate(env, brdf, method, samples, heuristic).stderr ** 2))
        for method in ("brdf", "light", "mis")
    }


@pytest.mark.slow
@pytest.mark.parametrize(
    "name", ["probulator/grace.hdr", "probulator/uffizi.hdr", "polyhaven/royal_esplanade_1k.hdr"]
)
def test_mis_has_lower_variance_than_either_strategy_on_a_glossy_brdf(shared_data, name):
    """On high-dynamic-range maps, MIS with N samples per strategy beats each strategy alone."""
    from brdfkit.brdf import parse

    env = EnvironmentMap.from_file(shared_data / "envmaps" / name)
    variance = _strategy_variances(env, parse("ggx(alpha=0.1)"))
    assert variance["mis"] < variance["brdf"] and variance["mis"] < variance["light"], variance


@pytest.mark.slow
def test_mis_stays_within_veachs_bound_where_brdf_sampling_is_nearly_ideal(shared_data):
    """On a smooth map, VNDF sampling is nearly ideal and MIS may lose, but only by the additive
    term of Veach's bound (1997, Thm 9.2): V_mis(N, N) ≤ V_brdf(N)/2 + μ²/(2N)."""
    from brdfkit.brdf import parse

    env = EnvironmentMap.from_file(shared_data / "envmaps" / "polyhaven" / "venice_sunset_1k.hdr")
    glossy = parse("ggx(alpha=0.1)")
    n = 2048
    variance = _strategy_variances(env, glossy, n, heuristic="balance")
    mu = _estimate(env, glossy, "brdf", 16384).value
    bound = variance["brdf"] / 2 + float(np.mean(mu**2)) / (2 * n)
    assert variance["mis"] <= bound, (variance, bound)
    assert variance["mis"] < variance["light"] / 10, variance


# --------------------------------------------------------------------------- optimal MIS
def test_optimal_mis_is_exact_where_the_integrand_is_proportional_to_a_pdf():
    """Lambertian under a uniform sky: g = ρL·p_cosine, so the fitted control variate takes
    all of it and the estimate is ρL to rounding, with a zero standard error."""
    wo = _directions(20, 1)
    e = reflected_radiance(
        Lambertian([0.7, 0.2]), UniformSky(2.5), wo, method="mis", heuristic="optimal", samples=64
    )
    np.testing.assert_allclose(e.value, [[0.7 * 2.5, 0.2 * 2.5]] * 20, rtol=1e-10)
    assert float(e.stderr.max()) < 1e-9


def test_optimal_mis_is_unbiased_where_the_brdf_sampler_leaves_the_hemisphere():
    """GGX's VNDF sampler returns 1-4 % of its directions below the surface (pdf 0 there): the
    control variate integrates to that fraction, not 1. Mean of 64 independent estimates ==
    quadrature within their standard error, per query."""
    from brdfkit.brdf import parse

    env = EnvironmentMap(np.random.default_rng(3).gamma(0.5, 2.0, size=(16, 32, 3)))
    glossy = parse("ggx(alpha=0.15)")
    wo = _directions(6, 7)
    exact = reflected_radiance(
        glossy, env, wo, method="quadrature", theta_steps=512, phi_steps=1024
    ).value
    runs = np.stack(
        [
            reflected_radiance(
                glossy, env, wo, method="mis", heuristic="optimal", samples=128, seed=s
            ).value
            for s in range(64)
        ]
    )
    stderr_of_mean = runs.std(axis=0) / np.sqrt(len(runs))
    assert np.all(np.abs(runs.mean(axis=0) - exact) < 4 * stderr_of_mean + 1e-4 * exact)


def test_optimal_mis_rejects_delta_lobes():
    from brdfkit.brdf import parse

    with pytest.raises(ValueError, match="heuristic='optimal' needs a BRDF without delta lobes"):
        reflected_radiance(
            parse("lambertian + mirror"), UniformSky(), np.array([0, 0, 1.0]), heuristic="optimal"
        )


def test_optimal_mis_runs_on_torch():
    torch = pytest.importorskip("torch")
    wo = torch.tensor(_directions(4, 2))
    e = reflected_radiance(
        Lambertian(0.5), UniformSky(1.0), wo, method="mis", heuristic="optimal", samples=16
    )
    assert isinstance(e.value, torch.Tensor)
    np.testing.assert_allclose(e.value.numpy(), 0.5, rtol=1e-10)


def _actual_errors(env, brdf, samples=256, seeds=8):
    """Mean squared error over 32 glossy queries and ``seeds`` runs of each estimator, against
    a 65,536-sample MIS reference."""
    reference = _estimate(env, brdf, "mis", 65536, seed=999).value
    return {
        method: float(
            np.mean(
                [
                    np.mean(
                        (_estimate(env, brdf, method, samples, heuristic, seed).value - reference)
                        ** 2
                    )
                    for seed in range(seeds)
                ]
            )
        )
        for method, heuristic in (("brdf", "power"), ("light", "power"), ("mis", "optimal"))
    }


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        "probulator/grace.hdr",
        "probulator/uffizi.hdr",
        "polyhaven/royal_esplanade_1k.hdr",
        "polyhaven/venice_sunset_1k.hdr",
    ],
)
def test_optimal_mis_has_lower_error_than_either_strategy_on_every_map(shared_data, name):
    """MIS with optimal weights and N samples per strategy: lower actual error than N samples
    of either strategy alone on a glossy GGX, on every map — also on venice_sunset, where
    VNDF sampling is nearly ideal and the power heuristic loses (Veach's bound)."""
    from brdfkit.brdf import parse

    env = EnvironmentMap.from_file(shared_data / "envmaps" / name)
    errors = _actual_errors(env, parse("ggx(alpha=0.1)"))
    assert errors["mis"] < errors["brdf"] and errors["mis"] < errors["light"], errors


@pytest.mark.parametrize(
    "spec",
    [
        "lambertian(albedo=[0.2, 0.5, 0.7])",
        "lambertian(albedo=0.3) + ggx(alpha=0.3)",
        "0.5 * lambertian(albedo=0.6) + 0.8 * ggx(alpha=0.2) + lambertian(albedo=0.1)",
    ],
)
def test_auto_takes_lambertian_lobes_from_the_irradiance_and_agrees_with_mis(spec):
    """ "auto" = ρE(n)/π + MC of the other lobes: equal to plain MIS within their errors."""
    from brdfkit.brdf import parse

    env = EnvironmentMap(np.random.default_rng(3).gamma(0.5, 2.0, size=(16, 32, 3)))
    normals = _directions(12, 6, upper=False)
    wo = normals + 0.4 * _directions(12, 7, upper=False)
    brdf = parse(spec)
    auto = reflected_radiance(brdf, env, wo, normal=normals, samples=4096, seed=1)
    mis = reflected_radiance(brdf, env, wo, normal=normals, method="mis", samples=65536, seed=2)
    spread = np.sqrt(auto.stderr**2 + mis.stderr**2)
    assert np.all(np.abs(auto.value - mis.value) <= 4.5 * spread + 1e-4 * np.abs(mis.value))
    if spec.startswith("lambertian(albedo=[0.2"):
        assert np.all(auto.stderr == 0)  # no Monte Carlo left


def test_auto_white_out_is_exact_for_any_normal_under_a_constant_map():
    env = EnvironmentMap(np.full((8, 16, 3), 1.5))
    normals = _directions(10, 2, upper=False)
    wo = normals + 0.3 * _directions(10, 3, upper=False)
    e = reflected_radiance(Lambertian(0.4), env, wo, normal=normals)
    below = np.sum(wo * normals, axis=-1) <= 0  # one-sided: nothing reflects below
    expected = np.where(below, 0.0, 0.6)[:, None] * np.ones(3)
    np.testing.assert_allclose(e.value, expected, rtol=1e-6)
    np.testing.assert_array_equal(e.stderr, 0.0)


def test_split_diffuse_finds_lambertian_lobes_in_sums_and_scales():
    from brdfkit.brdf import parse
    from brdfkit.render import split_diffuse

    rho, rest = split_diffuse(parse("0.5 * lambertian(albedo=0.6) + ggx(alpha=0.2)"))
    assert float(rho) == pytest.approx(0.3) and rest.spec_name == "ggx"
    assert split_diffuse(parse("lambertian(albedo=0.2)"))[1] is None
    ggx = parse("ggx(alpha=0.2)")
    assert split_diffuse(ggx) == (None, ggx)


def test_auto_control_variate_is_unbiased_and_cuts_the_variance_of_rough_diffuse_lobes():
    """method="auto" samples f − k with k·E(n) exact (diffuse_floor): the same mean as plain
    MIS within Monte Carlo error, at a fraction of its variance for an Oren–Nayar lobe."""
    from brdfkit.brdf import OrenNayar, RoughConductor
    from brdfkit.render import diffuse_floor

    rng = np.random.default_rng(3)
    env = EnvironmentMap(rng.random((16, 32, 3)) ** 3 * 4)
    theta = np.linspace(0.1, 1.4, 6)
    wo = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    rough = OrenNayar(rho=[0.6, 0.5, 0.4], sigma=0.4)
    for brdf in (rough, RoughConductor(alpha=0.3, material="Au") + 0.2 * rough):
        k = diffuse_floor(brdf, wo)
        assert np.all(k > 0)
        auto = reflected_radiance(brdf, env, wo, method="auto", samples=4096, seed=1)
        mis = reflected_radiance(brdf, env, wo, method="mis", samples=4096, seed=2)
        z = (auto.value - mis.value) / np.hypot(auto.stderr, mis.stderr)
        assert np.all(np.abs(z) < 4.5), z
    assert np.all(auto.stderr < mis.stderr)
    plain = reflected_radiance(rough, env, wo, method="mis", samples=4096, seed=2)
    controlled = reflected_radiance(rough, env, wo, method="auto", samples=4096, seed=1)
    ratio = controlled.stderr / plain.stderr
    assert np.all(ratio < 0.5) and np.median(ratio) < 0.2, ratio


def test_sobol_blocks_continue_one_sequence_and_seeds_may_be_per_query():
    """Calls with first_sample 0 and N draw the two halves of one 2N-point sequence per query;
    an array of per-query seeds gives what the integer seed derives for each query."""
    from brdfkit.brdf import RoughConductor
    from brdfkit.sampling import query_seeds

    env = EnvironmentMap(np.random.default_rng(2).random((8, 16, 3)) ** 3 * 4)
    brdf = RoughConductor(alpha=0.3, material="Au", masking="smith_separable")
    wo = _directions(5, seed=3)

    def radiance(**kwargs):
        kwargs = {"samples": 8, "seed": 4, "sequence": "sobol", **kwargs}
        return reflected_radiance(brdf, env, wo, **kwargs).value

    whole = radiance(samples=16)
    halves = (radiance() + radiance(first_sample=8)) / 2
    np.testing.assert_allclose(halves, whole, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(radiance(seed=query_seeds(4, 5)), radiance())
    assert not np.allclose(radiance(first_sample=8), radiance())
    with pytest.raises(ValueError, match="sobol"):
        radiance(seed=query_seeds(4, 5), sequence="random")
    with pytest.raises(ValueError, match=r"shape \(5,\)"):
        radiance(seed=query_seeds(4, 3))
