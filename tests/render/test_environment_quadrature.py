"""Deterministic environment-map quadrature against the Monte Carlo renderer."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.brdf.base import BRDF, Sample
from brdfkit.data import default_envmap_path
from brdfkit.interop.mitsuba import relative_rmse
from brdfkit.light import DirectionalLight, EnvironmentMap
from brdfkit.render import Camera, Sphere, gbuffer, quadrature_sphere, render_sphere
from brdfkit.render import environment_quadrature as env_quadrature
from brdfkit.render.environment_quadrature import error_estimate
from brdfkit.render.scene import interior_mask

RES = 24
BOUND = 0.005
"""Allowed relative RMSE (quadrature − MC) beyond three times MC's own estimated noise."""


@pytest.fixture(scope="module")
def env() -> EnvironmentMap:
    return EnvironmentMap.from_file(default_envmap_path())


MODELS = [
    "ggx(alpha=0.2, material='Au')",
    "phong(kd=0.0, ks=0.02, n=100.0)",
    "blinn_phong(kd=0.0, ks=1.0, n=1000.0)",
    "oren_nayar(rho=0.5, sigma=0.3)",
    "rough_dielectric(alpha=0.1, eta=1.5)",
    "plastic(diffuse_reflectance=0.5, specular_reflectance=1.0, eta=1.49)",
    "hapke(w=0.6, xi=0.3, b0=0.5, h=0.2)",
    "ggx(alpha=0.3, material='Cu') + lambertian(rho=0.3)",
]


@pytest.mark.slow
@pytest.mark.parametrize("spec", MODELS)
def test_matches_monte_carlo(env, spec):
    model = parse(spec)
    mask = interior_mask(RES)
    q = quadrature_sphere(model, env, RES)
    a = render_sphere(model, env, RES, samples=256, seed=1, compiled=False)
    b = render_sphere(model, env, RES, samples=256, seed=2, compiled=False)
    noise = relative_rmse(a, b, mask) / 2  # of the mean (a + b)/2
    error = relative_rmse(q.image, (a + b) / 2, mask)
    assert error <= 3 * noise + BOUND, (error, noise)
    assert q.error <= 0.01  # the goal
    outside = np.hypot(*np.meshgrid(*(2 * [(np.arange(RES) + 0.5) * 2 / RES - 1]))) >= 1
    assert np.all(q.image[outside] == 0)


def test_refining_lowers_the_error(env):
    model = parse("blinn_phong(kd=0.0, ks=1.0, n=1000.0)")
    mask = interior_mask(RES)
    images = [quadrature_sphere(model, env, RES, level=lv).image for lv in range(4)]
    steps = [relative_rmse(images[i], images[i + 1], mask) for i in range(3)]
    assert steps[2] < steps[1] < steps[0]


def test_error_estimate_trusts_a_rate_only_once_the_steps_shrink():
    assert error_estimate(0.004, None) == 0.008  # one step: twice it
    assert error_estimate(0.01, 0.005) == 0.02  # growing: twice it
    assert error_estimate(0.01, 0.1) == pytest.approx(0.01 / 3)  # rate floored at 1/4
    assert error_estimate(0.006, 0.01) == pytest.approx(0.006 * 0.6 / 0.4)  # slow: > the step


@pytest.mark.slow
@pytest.mark.parametrize(
    "spec", ["blinn_phong(kd=0.0, ks=1.0, n=1000.0)", "modified_phong(kd=0.0, ks=1.0, n=500.0)"]
)
def test_the_image_returned_is_within_the_goal_of_the_next_level(env, spec):
    model = parse(spec)
    mask = interior_mask(48)
    q = quadrature_sphere(model, env, 48)
    finer = quadrature_sphere(model, env, 48, level=q.level + 1).image
    assert relative_rmse(q.image, finer, mask) <= 0.01


def test_lambertian_is_exact(env):
    model = parse("lambertian(rho=0.5)")
    q = quadrature_sphere(model, env, RES)
    mc = render_sphere(model, env, RES, samples=1)  # its irradiance table: no noise, no kernels
    assert q.nodes == 0
    np.testing.assert_allclose(q.image, mc, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("spec", ["mirror(reflectance=1.0)", "smooth_dielectric(eta=1.5)"])
def test_refuses_delta(env, spec):
    with pytest.raises(ValueError, match="model without delta lobes"):
        quadrature_sphere(parse(spec), env, RES)


def test_refuses_other_lights():
    with pytest.raises(ValueError, match="EnvironmentMap"):
        quadrature_sphere(parse("phong(ks=0.5, n=10.0)"), DirectionalLight(), RES)


@pytest.mark.parametrize(
    ("level", "roughness"),
    [(0, "alpha=0.3"), (2, "alpha=0.3"), (0, "alpha=0.1, alpha_u=0.1, alpha_v=0.3")],
)
def test_a_grey_kernel_serves_every_channel_of_the_map(env, level, roughness):
    # a grey model's kernel is transformed once and meets each channel of the map's spectrum:
    # the image of the same model with three equal channels, to rounding (also the kernels
    # of an anisotropic model's tangent angles and their mirror images)
    grey = parse(f"ggx({roughness}, eta=1.5)")
    rgb = parse(f"ggx({roughness}, eta=[1.5, 1.5, 1.5])")
    assert (grey.channels, rgb.channels, env.channels) == (1, 3, 3)
    a = quadrature_sphere(grey, env, RES, level=level)
    b = quadrature_sphere(rgb, env, RES, level=level)
    assert a.image.shape == b.image.shape == (RES, RES, 3) and a.nodes == b.nodes
    assert np.ptp(a.image[RES // 2, RES // 2]) > 0  # the map's colour reaches the image
    np.testing.assert_allclose(a.image, b.image, rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- anisotropic
ANISOTROPIC = [
    "ggx(alpha=0.1, alpha_u=0.05, alpha_v=0.3)",
    "ward(kd=0.3, ks=0.6, alpha_x=0.1, alpha_y=0.4)",
    "ashikhmin_shirley(rd=0.3, rs=0.1, nu=10.0, nv=1000.0)",
    "principled(base_color=0.5, roughness=0.3, anisotropic=0.8)",
]


@dataclass(frozen=True, eq=False)
class Turned(BRDF):
    """``inner`` with its tangent turned by ``angle`` about the normal and, with ``skew``, its
    values scaled by 1 + skew·(wi_x + wo_x)/2 (> 0, reciprocal): a model with neither the
    mirror symmetry about the tangent nor (with skew) the one under a turn by π."""

    inner: BRDF
    angle: float = 0.0
    skew: float = 0.0
    isotropic = False

    @property
    def channels(self) -> int:  # type: ignore[override]
        return self.inner.channels

    def _turn(self, v, sign: float = 1.0):
        c, s = math.cos(sign * self.angle), math.sin(sign * self.angle)
        v = np.asarray(v, dtype=float)
        return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1],
                         v[..., 2]], axis=-1)  # fmt: skip

    def _factor(self, wi, wo):
        return (1 + self.skew * (np.asarray(wi)[..., 0] + np.asarray(wo)[..., 0]) / 2)[..., None]

    def eval(self, wi, wo):
        return self.inner.eval(self._turn(wi), self._turn(wo)) * self._factor(wi, wo)

    def pdf(self, wi, wo):
        return self.inner.pdf(self._turn(wi), self._turn(wo))

    def sample(self, wo, u):
        s = self.inner.sample(self._turn(wo), u)
        wi = self._turn(s.wi, -1.0)
        return Sample(wi, s.weight * self._factor(wi, wo), s.pdf, s.delta)

    def sampling_weight(self, wo):
        return self.inner.sampling_weight(self._turn(wo))


@dataclass(frozen=True, eq=False)
class Flagged(BRDF):
    """An isotropic ``inner`` that says it is anisotropic: the anisotropic path's input."""

    inner: BRDF
    isotropic = False

    @property
    def channels(self) -> int:  # type: ignore[override]
        return self.inner.channels

    def eval(self, wi, wo):
        return self.inner.eval(wi, wo)


@pytest.mark.slow
@pytest.mark.parametrize("spec", ANISOTROPIC)
def test_anisotropic_matches_monte_carlo(env, spec):
    # the pixels' tangents follow latitude lines about world +z, seen from the side: the
    # quadrature must render the very sphere the Monte Carlo renderer does
    model = parse(spec)
    assert not model.isotropic
    mask = interior_mask(RES)
    q = quadrature_sphere(model, env, RES)
    a = render_sphere(model, env, RES, samples=512, seed=1, compiled=False)
    b = render_sphere(model, env, RES, samples=512, seed=2, compiled=False)
    noise = relative_rmse(a, b, mask) / 2
    error = relative_rmse(q.image, (a + b) / 2, mask)
    assert error <= 3 * noise + BOUND, (error, noise)
    assert q.error <= 0.01 and q.gammas >= env_quadrature.GAMMA_START


@pytest.mark.slow
def test_a_model_without_symmetries_matches_monte_carlo(env):
    # turned by 0.5 rad and skewed: neither mirror symmetric nor periodic under a turn by π,
    # so every tangent angle of the full turn is evaluated
    model = Turned(parse("ggx(alpha=0.1, alpha_u=0.08, alpha_v=0.3)"), angle=0.5, skew=0.6)
    assert env_quadrature._rotation_symmetry(model) == (2 * math.pi, False)
    mask = interior_mask(RES)
    q = quadrature_sphere(model, env, RES)
    a = render_sphere(model, env, RES, samples=512, seed=1, compiled=False)
    b = render_sphere(model, env, RES, samples=512, seed=2, compiled=False)
    noise = relative_rmse(a, b, mask) / 2
    error = relative_rmse(q.image, (a + b) / 2, mask)
    assert error <= 3 * noise + BOUND, (error, noise)


def test_rotation_symmetry_is_measured():
    aniso = parse("ggx(alpha=0.1, alpha_u=0.05, alpha_v=0.3)")
    assert env_quadrature._rotation_symmetry(aniso) == (math.pi, True)
    assert env_quadrature._rotation_symmetry(Turned(aniso, angle=0.5)) == (math.pi, False)
    assert env_quadrature._rotation_symmetry(Turned(aniso, skew=0.5)) == (2 * math.pi, True)


@pytest.mark.parametrize("symmetry", [(math.pi, False), (2 * math.pi, True), (2 * math.pi, False)])
def test_the_symmetries_only_save_work(env, monkeypatch, symmetry):
    # the kernels of −γ mirrored from those of γ, and a period of π, give the image of
    # every kernel evaluated over the full turn, to rounding, with fewer evaluations
    model = parse("ward(kd=0.0, ks=0.6, alpha_x=0.1, alpha_y=0.4)")
    both = quadrature_sphere(model, env, RES, level=0, gammas=8)
    monkeypatch.setattr(env_quadrature, "_rotation_symmetry", lambda m: symmetry)
    plain = quadrature_sphere(model, env, RES, level=0, gammas=8 if symmetry[0] == math.pi else 16)
    np.testing.assert_allclose(plain.image, both.image, rtol=1e-9, atol=1e-12)
    assert plain.nodes > both.nodes


def test_an_isotropic_model_on_the_anisotropic_path_gives_the_isotropic_image(env):
    model = parse("ggx(alpha=0.2, material='Au')")
    iso = quadrature_sphere(model, env, RES)
    flagged = quadrature_sphere(Flagged(model), env, RES)
    assert iso.gammas == 1 and flagged.gammas == env_quadrature.GAMMA_START
    assert (flagged.level, flagged.error) == (iso.level, pytest.approx(iso.error, abs=1e-12))
    np.testing.assert_allclose(flagged.image, iso.image, rtol=1e-10, atol=1e-14)


def test_the_pixel_tangent_angle_of_the_front_view():
    # latitude tangents (world +z is the camera's y) seen from the side: the pixel's tangent
    # is turned by γ = atan2(−cos θ sin ψ, cos ψ) from the ring tangent rotated by ψ
    camera = Camera()
    g = gbuffer(Sphere(), camera, 32)
    frame = np.asarray(camera.rotation, dtype=float)
    local = g.normals[g.mask] @ frame
    r, psi = np.hypot(local[:, 0], local[:, 1]), np.arctan2(local[:, 1], local[:, 0])
    gamma = env_quadrature._pixel_frames(g, frame, local, r, psi)
    expected = np.arctan2(-local[:, 2] * np.sin(psi), np.cos(psi))
    np.testing.assert_allclose(np.angle(np.exp(1j * (gamma - expected))), 0, atol=1e-12)


def test_trigonometric_weights_interpolate_a_band_limited_function():
    count = 8
    beta = np.linspace(-4.0, 7.0, 50)
    nodes = np.arange(count) * 2 * math.pi / count

    def f(x):
        return 1.5 + np.cos(x) - 0.5 * np.sin(3 * x) + 0.25 * np.cos(4 * x)  # Nyquist: cosine

    weights = env_quadrature._trigonometric_weights(beta, count)
    np.testing.assert_allclose(weights @ f(nodes), f(beta), atol=1e-12)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.slow
def test_the_anisotropic_image_is_within_the_goal_of_the_next_level(env):
    # the next level: the grid twice as fine and every tangent angle (GAMMA_MAX)
    model = parse("ashikhmin_shirley(rd=0.3, rs=0.1, nu=10.0, nv=1000.0)")
    mask = interior_mask(48)
    q = quadrature_sphere(model, env, 48)
    finer = quadrature_sphere(model, env, 48, level=q.level + 1)
    assert finer.gammas == env_quadrature.GAMMA_MAX
    assert q.error <= 0.01
    assert relative_rmse(q.image, finer.image, mask) <= 0.01


@pytest.mark.slow
def test_anisotropic_from_another_view_matches_monte_carlo(env):
    # seen from above at a slant, the pole of the latitude tangents is on the sphere's face
    camera = Camera.look_at((4.0, 3.0, 8.0), kind="orthographic")
    model = parse("ward(kd=0.0, ks=0.8, alpha_x=0.08, alpha_y=0.3)")
    mask = interior_mask(RES)
    q = quadrature_sphere(model, env, RES, camera=camera)
    a = render_sphere(model, env, RES, camera=camera, samples=512, seed=1, compiled=False)
    b = render_sphere(model, env, RES, camera=camera, samples=512, seed=2, compiled=False)
    noise = relative_rmse(a, b, mask) / 2
    error = relative_rmse(q.image, (a + b) / 2, mask)
    assert error <= 3 * noise + BOUND, (error, noise)


def test_the_atlas_renders_anisotropic_spheres_by_quadrature(env):
    from brdfkit.report.atlas import env_sphere

    image, spent = env_sphere(parse("ward(kd=0.3, ks=0.6, alpha_x=0.1, alpha_y=0.4)"), env, RES)
    assert isinstance(spent, str) and spent.startswith("quadrature")
    assert image.shape == (RES, RES, 3)


@pytest.mark.parametrize("rows", [3, 40_000])
def test_kernel_values_in_chunks_equal_each_tangent_angle_evaluated_alone(monkeypatch, rows):
    """A ring's nodes of several γ, in chunks of whole γ rows (short rows) or of pieces of
    one (long rows), with ωo a broadcast view: bitwise the values of each γ's nodes
    evaluated at once as plain arrays."""
    monkeypatch.setattr(env_quadrature, "_EVAL_CHUNK", 1000)
    model = parse("beckmann(alpha_u=0.4, alpha_v=0.1)")
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-0.7, 0.7, size=(2, rows))
    z = np.sqrt(1 - x * x - y * y)
    gammas = [0.3, 1.1, 2.0]
    wi, wo = env_quadrature._ring_nodes(x, y, z, gammas, 0.6, 0.8)
    assert wo.strides[1] == 0
    values = env_quadrature._kernel_values(model, wi, wo)
    for g in range(len(gammas)):
        alone = model.eval(np.array(wi[g]), np.array(wo[g])) * wi[g][:, 2:3]
        np.testing.assert_array_equal(values[g], alone)


def test_cell_radiance_does_not_depend_on_its_bands(monkeypatch):
    """Bands of one row of cells or of all rows at once: bitwise the same cell averages."""
    env = EnvironmentMap(np.random.default_rng(6).gamma(0.5, 2.0, size=(16, 32, 3)))
    frame = np.array([[0.6, 0.0, 0.8], [0.0, 1.0, 0.0], [-0.8, 0.0, 0.6]])
    cells = []
    for chunk in (1, 1 << 30):
        monkeypatch.setattr(env_quadrature, "_LOOKUP_CHUNK", chunk)
        env_quadrature._LV_CACHE.clear()
        cells.append(env_quadrature._cell_radiance(env, frame, 8, 16))
    np.testing.assert_array_equal(cells[0], cells[1])
    assert cells[0].shape == (8, 16, 3) and np.all(cells[0] > 0)
