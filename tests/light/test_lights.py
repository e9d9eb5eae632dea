"""Light sources: sampling densities, closed-form irradiance, environment maps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.checks import chi2_test
from brdfkit.errors import ParameterError, SpecError
from brdfkit.light import (
    DirectionalLight,
    DiskLight,
    EnvironmentMap,
    PointLight,
    RectangleLight,
    SphereLight,
    UniformSky,
    parse_light,
)
from brdfkit.render import reflected_radiance

ORIGIN = np.zeros(3)


def _mc_irradiance(light, n=200_000, seed=1):
    """E at the origin facing +z by sampling the light (an independent check of sample())."""
    u = np.random.default_rng(seed).random((n, 2))
    s = light.sample(np.zeros((n, 3)), u)
    return np.mean(s.value[:, 0] * np.clip(s.wi[:, 2], 0, None))


def test_sphere_light_irradiance_is_pi_l_sin2_alpha():
    light = SphereLight(center=(0, 0, 3.0), radius=1.0, radiance=2.0)
    sin2_alpha = (1 / 3) ** 2
    assert abs(_mc_irradiance(light) - math.pi * 2.0 * sin2_alpha) < 1e-3  # exact per sample


def test_disk_light_irradiance_matches_closed_form():
    # On-axis disk facing the receiver: E = π L R² / (R² + d²).
    light = DiskLight(center=(0, 0, 2.0), normal=(0, 0, -1), radius=1.0, radiance=1.5)
    exact = math.pi * 1.5 * 1 / (1 + 4)
    assert abs(_mc_irradiance(light) - exact) / exact < 5e-3


def test_rectangle_light_irradiance_matches_quadrature_of_its_radiance():
    light = RectangleLight(corner=(-0.5, -1, 1.5), edge_u=(0, 2, 0), edge_v=(1, 0, 0), radiance=1.0)
    # E = ∫∫ L cosθ cosθ' / r² dA over the rectangle (plane z = 1.5 facing down).
    x, y = np.meshgrid(
        np.linspace(-0.5, 0.5, 801)[:-1] + 1 / 1600, np.linspace(-1, 1, 1601)[:-1] + 1 / 1600
    )
    r2 = x * x + y * y + 1.5**2
    exact = np.sum(1.5 * 1.5 / r2**2) * (1 / 800) * (2 / 1600)
    assert abs(_mc_irradiance(light) - exact) / exact < 5e-3


@pytest.mark.parametrize(
    "light",
    [
        SphereLight(center=(0.3, 0.2, 2.0), radius=0.7),
        DiskLight(center=(0.2, 0, 1.0), normal=(0, 0.3, -1), radius=0.8),
        RectangleLight(corner=(-0.5, -0.5, 1.0), edge_u=(0, 1.2, 0), edge_v=(1, 0, 0.2)),
        UniformSky(1.0),
    ],
    ids=["sphere", "disk", "rectangle", "sky"],
)
def test_light_sampler_passes_chi2_against_its_pdf(light):
    result = chi2_test(
        lambda u: light.sample(np.zeros((*u.shape[:-1], 3)), u).wi,
        lambda w: light.pdf(np.zeros((*w.shape[:-1], 3)), w),
        sphere=True,
    )
    assert result.passed, result


def test_sample_value_is_radiance_over_pdf():
    light = SphereLight(center=(0, 0.5, 2.0), radius=0.5, radiance=[1.0, 2.0, 3.0])
    u = np.random.default_rng(0).random((1000, 2))
    pts = np.zeros((1000, 3))
    s = light.sample(pts, u)
    np.testing.assert_allclose(
        s.value * s.pdf[:, None], light.incident_radiance(pts, s.wi), rtol=1e-6
    )
    np.testing.assert_allclose(light.pdf(pts, s.wi), s.pdf, rtol=1e-10)


def test_point_light_follows_inverse_square_law():
    light = PointLight(position=(0, 0, 1.0), intensity=4.0)
    pts = np.array([[0, 0, 0.0], [0, 0, -1.0], [0, 0, -3.0]])
    e = light.sample(pts, None).value[:, 0]
    np.testing.assert_allclose(e, 4.0 / np.array([1.0, 4.0, 16.0]), rtol=1e-12)
    with pytest.raises(ValueError, match="point light"):
        light.sample(np.array([[0, 0, 1.0]]), None)


def test_directional_light_validation():
    with pytest.raises(ValueError, match="irradiance must be in"):
        DirectionalLight((0, 0, 1), irradiance=-1.0)
    with pytest.raises(ValueError, match="direction must be a non-zero vector"):
        DirectionalLight((0, 0, 0))
    with pytest.raises(ValueError, match="direction must have a last axis of length 3"):
        DirectionalLight((0, 1))


@pytest.mark.parametrize("compensated", [False, True])
def test_environment_map_sampling_pdf_and_lookup(compensated):
    """Texel-aligned χ²: the expected count of each texel is exact (no quadrature needed)."""
    from scipy.stats import chisquare

    from brdfkit.geometry import cartesian_to_spherical
    from brdfkit.light.spherical_harmonics import latlong_directions, latlong_solid_angles

    rng = np.random.default_rng(3)
    h, w = 16, 32
    image = rng.random((h, w, 3)) ** 4 * 10
    env = EnvironmentMap(image, rotation=_rot_z(0.4))
    env = env.compensated if compensated else env
    n = 400_000
    s = env.sample(np.zeros((n, 3)), rng.random((n, 2)))
    theta, phi = cartesian_to_spherical(s.wi @ _rot_z(0.4))  # back to the map frame
    rows = np.clip((theta / math.pi * h).astype(int), 0, h - 1)
    cols = ((phi % (2 * math.pi)) / (2 * math.pi) * w).astype(int) % w
    observed = np.bincount(rows * w + cols, minlength=h * w)
    # a texel's probability: its (constant) density on the unit square, p_ω·2π² sin θ, over H·W
    d = latlong_directions(h, w) @ _rot_z(0.4).T
    sin_theta = np.sin((np.arange(h) + 0.5) * math.pi / h)[:, None]
    expected = env.pdf(ORIGIN, d) * 2 * math.pi**2 * sin_theta / (h * w)
    assert abs(expected.sum() - 1) < 1e-9
    assert chisquare(observed, n * expected.ravel()).pvalue > 1e-3
    np.testing.assert_allclose(env.pdf(np.zeros((1000, 3)), s.wi[:1000]), s.pdf[:1000], rtol=1e-4)
    # the pdf integrates to 1 on a fine grid; the pixel-centre lookup returns the pixel itself
    fine = latlong_directions(256, 512)
    assert abs(np.sum(env.pdf(ORIGIN, fine) * latlong_solid_angles(256, 512)) - 1) < 1e-4
    np.testing.assert_allclose(env.incident_radiance(ORIGIN, d), image, rtol=1e-5, atol=1e-9)


def test_compensated_map_samples_what_is_brighter_than_the_mean():
    """Karlík et al. 2019: density ∝ max(L − L̄, 0)·sin θ plus the floor; same radiance (L
    of a texel: the mean of its bilinear lookup's mean and its 3×3 maximum)."""
    from scipy.ndimage import correlate1d, maximum_filter

    from brdfkit.light.spherical_harmonics import latlong_directions

    rng = np.random.default_rng(5)
    h, w = 16, 32
    image = rng.random((h, w, 3)) ** 4 * 10
    env = EnvironmentMap(image, rotation=_rot_z(0.4), scale=2.0)
    view = env.compensated
    assert view is env.compensated and view.compensated is view
    d = latlong_directions(h, w) @ _rot_z(0.4).T
    np.testing.assert_array_equal(
        view.incident_radiance(ORIGIN, d), env.incident_radiance(ORIGIN, d)
    )
    p, p_c = env.pdf(ORIGIN, d), view.pdf(ORIGIN, d)
    assert np.all(p_c > 0)  # the floor: light sampling alone stays unbiased
    lum = image @ np.array([0.2126, 0.7152, 0.0722])
    sin_theta = np.sin((np.arange(h) + 0.5) * math.pi / h)[:, None]
    mean = np.sum(lum * sin_theta) / (np.sum(sin_theta) * w)
    tent = [1 / 8, 3 / 4, 1 / 8]  # the bilinear lookup's mean over a texel, axis by axis
    texel_mean = correlate1d(correlate1d(lum, tent, 0, mode="nearest"), tent, 1, mode="wrap")
    peak = (maximum_filter(lum, size=3, mode=("nearest", "wrap")) + texel_mean) / 2
    dim, bright = peak < mean, peak > 2 * mean
    assert dim.any() and bright.any()
    # texels darker than the mean keep only the floor; the bright ones gain density
    assert np.max(p_c[dim]) < 0.01 * np.min(p_c[bright])
    # the chance of drawing a texel darker than the mean falls more than tenfold
    assert np.sum((p_c * sin_theta)[dim]) < 0.1 * np.sum((p * sin_theta)[dim])
    ratio = p_c / (np.maximum(peak - mean, 0) + 1e-3 * peak.mean())  # the solid-angle pdf
    np.testing.assert_allclose(ratio, ratio.mean(), rtol=1e-5)  # float32 image


def test_compensated_mis_is_unbiased_and_less_noisy(monkeypatch):
    """A glossy lobe under a sun-and-sky map: MIS with the compensated light density agrees
    with quadrature and has less variance than MIS with the plain density."""
    from brdfkit.brdf import RoughConductor

    h, w = 32, 64
    theta = (np.arange(h) + 0.5) * math.pi / h
    sky = np.broadcast_to((0.5 + 0.5 * np.cos(theta))[:, None, None], (h, w, 3)).copy()
    sky[6:8, 20:22] += 60.0  # a sun
    env = EnvironmentMap(sky)
    brdf = RoughConductor(alpha=0.3, material="Au")
    wo = np.array([0.3, 0.1, 1.0]) / np.linalg.norm([0.3, 0.1, 1.0])
    normals = np.array([[0.0, 0.0, 1.0], [0.4, 0.0, 0.9], [0.0, -0.5, 0.8]])
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    q = reflected_radiance(
        brdf, env, wo, normal=normals, method="quadrature", theta_steps=512, phi_steps=1024
    ).value
    kwargs = dict(normal=normals, method="mis", samples=20_000, seed=2)
    compensated = reflected_radiance(brdf, env, wo, **kwargs)
    np.testing.assert_allclose(compensated.value, q, atol=5 * compensated.stderr.max())
    monkeypatch.setattr(EnvironmentMap, "compensated", property(lambda self: self))
    plain = reflected_radiance(brdf, env, wo, **kwargs)
    np.testing.assert_allclose(plain.value, q, atol=5 * plain.stderr.max())
    variance_ratio = (plain.stderr[..., 1] / compensated.stderr[..., 1]) ** 2
    assert np.all(variance_ratio > 1.05) and variance_ratio.max() > 1.5


def test_environment_map_errors():
    with pytest.raises(ValueError, match="image must be an \\(H, W, C\\)"):
        EnvironmentMap(np.ones((4, 4)))
    with pytest.raises(ValueError, match="non-negative"):
        EnvironmentMap(-np.ones((4, 8, 3)))
    with pytest.raises(ValueError, match="rotation"):
        EnvironmentMap(np.ones((4, 8, 3)), rotation=np.ones((3, 3)))


def test_mirror_ball_round_trip_recovers_the_map():
    """Render a mirror ball in a known map, convert the photo back; compare off the blind spot."""
    from brdfkit.light.spherical_harmonics import latlong_directions

    h, w = 32, 64
    d = latlong_directions(h, w)
    image = np.stack([0.5 + 0.5 * d[..., 0], 0.5 + 0.5 * d[..., 1], 0.5 + 0.5 * d[..., 2]], axis=-1)
    env = EnvironmentMap(image)
    res = 512
    y, x = np.mgrid[0:res, 0:res]
    xc, yc = (x + 0.5) / res * 2 - 1, 1 - (y + 0.5) / res * 2
    inside = xc**2 + yc**2 < 1
    zc = np.sqrt(np.clip(1 - xc**2 - yc**2, 0, None))
    n_world = np.stack([zc, xc, yc], axis=-1)  # world = (z_cam, x_cam, y_cam)
    v = np.array([1.0, 0, 0])
    r = 2 * (n_world @ v)[..., None] * n_world - v
    photo = np.where(inside[..., None], env.incident_radiance(ORIGIN, r), 0)
    back = EnvironmentMap.from_mirror_ball(photo, h, w)
    seen = d @ v > -0.5  # away from the blind spot behind the ball
    err = np.abs(back.image - image)[seen]
    assert err.mean() < 0.01 and err.max() < 0.1


def _rot_z(a):
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


@pytest.mark.parametrize(
    ("spec", "error", "match"),
    [
        ("directional:nan,0,1", ParameterError, "direction must be finite"),
        ("directional:0,0,0", ParameterError, "direction must be a non-zero vector"),
        ("directional:0,0,1:-1", ParameterError, "irradiance must be in"),
        ("directional:0,0,1:inf", ParameterError, "irradiance must be finite"),
        ("point:0,0,1:1e13", ParameterError, r"intensity must be in \[0.0, 1000000000000.0\]"),
        ("point:1e308,0,1", ParameterError, "position must be in"),
        ("sky:-0.5", ParameterError, "radiance must be in"),
        ("sky:1e999", ParameterError, "radiance must be finite"),
        ("envmap:/no/such/file.hdr:-1", ParameterError, "scale must be in"),
        ("directional:1,2", SpecError, "expected 3 comma-separated numbers"),
        ("directional:1,2,3:4:5", SpecError, "'4:5' is no number"),
        ("directional:a,b,c", SpecError, "'a' is no number"),
        ("point", SpecError, "expected 3 comma-separated numbers"),
        ("sky:bright", SpecError, "'bright' is no number"),
        ("spot:0,0,1", SpecError, "unknown kind 'spot'"),
        ("", SpecError, "unknown kind ''"),
        ("directional:" + "1," * 100_000 + "1", SpecError, "at most"),
    ],
)
def test_light_specs_raise_spec_errors_for_grammar_and_parameter_errors_for_values(
    spec, error, match
):
    with pytest.raises(error, match=match):
        parse_light(spec)


def test_light_specs_parse_and_normalise_any_finite_direction():
    light = parse_light("directional:1e300,1e300,0:2")
    np.testing.assert_allclose(light.direction, [2**-0.5, 2**-0.5, 0], rtol=1e-15)
    assert parse_light("sky").radiance == 1.0
    assert parse_light("point:0,0,2:5").intensity == 5.0
    with pytest.raises(SpecError, match="must be a string"):
        parse_light(None)


@pytest.mark.parametrize(
    "make",
    [
        lambda: DirectionalLight("up"),
        lambda: DirectionalLight((0, 0, 1), irradiance=None),
        lambda: PointLight((0, 0, "1")),
        lambda: PointLight(position=[[0, 0], [1]]),
        lambda: SphereLight(radius=0.0),
        lambda: SphereLight(radius=1e300),
        lambda: DiskLight(normal=(0, 0, 0)),
        lambda: RectangleLight(edge_u=(1e-200, 0, 0), edge_v=(0, 1e-200, 0)),
        lambda: UniformSky(radiance=True),
        lambda: EnvironmentMap("not an image"),
        lambda: EnvironmentMap(np.ones((4, 8, 3)), rotation=np.full((3, 3), np.nan)),
        lambda: EnvironmentMap(np.ones((4, 8, 3)), scale=-1.0),
    ],
)
def test_light_constructors_raise_parameter_errors(make):
    with pytest.raises(ParameterError):
        make()


def test_environment_map_irradiance_of_a_constant_map_is_pi_l_exactly():
    env = EnvironmentMap(
        np.full((8, 16, 3), 0.7), rotation=np.array([[0, 0, 1.0], [1, 0, 0], [0, 1, 0]])
    )
    normals = np.random.default_rng(0).normal(size=(50, 3))
    np.testing.assert_allclose(env.irradiance(normals), 0.7 * np.pi, rtol=1e-6)
    assert env.irradiance_table.shape == (97, 192, 3)


def test_environment_map_irradiance_equals_monte_carlo_within_its_error():
    """E(n) against a light-sampled estimate of ∫ L max(n·ω, 0) dω for a rough, rotated map."""
    from brdfkit.brdf import Lambertian
    from brdfkit.render import reflected_radiance

    image = np.random.default_rng(3).gamma(0.5, 2.0, size=(24, 48, 3))
    angle = 0.7
    rotation = np.array(
        [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    env = EnvironmentMap(image, scale=2.0, rotation=rotation)
    normals = np.random.default_rng(4).normal(size=(30, 3))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    estimate = reflected_radiance(
        Lambertian(1.0), env, normals, normal=normals, method="light", samples=100_000, seed=5
    )
    z = (env.irradiance(normals) - np.pi * estimate.value) / (np.pi * estimate.stderr)
    assert np.max(np.abs(z)) < 4.5, np.max(np.abs(z))


@pytest.mark.data
def test_environment_map_irradiance_matches_the_full_resolution_pixel_sum(shared_data):
    """Against :func:`brdfkit.light.spherical_harmonics.irradiance_brute_force` over every pixel of
    a sunny map: measured 0.28 % of the largest E at worst (at the sun's terminator), 0.11 % RMS."""
    from brdfkit.light.spherical_harmonics import irradiance_brute_force

    env = EnvironmentMap.from_file(shared_data / "envmaps/polyhaven/royal_esplanade_1k.hdr")
    normals = np.random.default_rng(0).normal(size=(300, 3))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    brute = irradiance_brute_force(env.image.astype(np.float64), normals)
    error = env.irradiance(normals) - brute
    assert np.max(np.abs(error)) < 0.005 * brute.max()
    assert np.sqrt(np.mean((error / brute) ** 2)) < 0.003


def test_environment_map_makes_its_sampling_distribution_when_first_sampled():
    """Only looked up, a map never builds its light-sampling distribution; sampling does,
    once, and its density is the one :meth:`pdf` gives."""
    env = EnvironmentMap(np.random.default_rng(2).gamma(0.5, 2.0, size=(16, 32, 3)))
    env.incident_radiance(np.zeros(3), np.array([[0.0, 0.6, 0.8]]))
    assert "_distribution" not in vars(env)
    drawn = env.sample(np.zeros(3), np.random.default_rng(3).random((64, 2)))
    assert "_distribution" in vars(env)
    np.testing.assert_allclose(env.pdf(np.zeros(3), drawn.wi), drawn.pdf, rtol=1e-6)
