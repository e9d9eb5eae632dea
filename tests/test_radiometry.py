"""Tests of brdfkit.radiometry: closed forms, the numerical surface integral, independent oracles
(scipy quadrature, Girard's theorem, Monte Carlo), properties, backends and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate
from scipy.spatial.transform import Rotation

from brdfkit import radiometry as rad
from brdfkit._array import to_numpy
from brdfkit.geometry import frame_from_normal, to_world
from brdfkit.sampling import square_to_spherical_triangle_pdf, square_to_uniform_cone

ORIGIN = np.zeros(3)
Z = np.array([0.0, 0.0, 1.0])


def disk_oracle(radius: float, s: float, h: float) -> float:
    """Ω of a disk by scipy quadrature in polar coordinates about the foot of the point:
    Ω = ∫ [h/√(h²+ρ₁²) − h/√(h²+ρ₂²)] dφ, ρ₁,₂ where the ray from the foot crosses the rim."""

    def integrand(phi):
        disc = radius**2 - (s * math.sin(phi)) ** 2
        if disc <= 0:
            return 0.0
        lo = max(0.0, s * math.cos(phi) - math.sqrt(disc))
        hi = max(0.0, s * math.cos(phi) + math.sqrt(disc))
        return h / math.hypot(h, lo) - h / math.hypot(h, hi)

    if s > radius:
        edge = math.asin(radius / s)
        return integrate.quad(integrand, -edge, edge, epsabs=1e-14, epsrel=1e-13, limit=200)[0]
    points = [-math.pi / 2, 0.0, math.pi / 2]
    return integrate.quad(
        integrand, -math.pi, math.pi, points=points, epsabs=1e-14, epsrel=1e-13, limit=200
    )[0]


# --------------------------------------------------------------------------- closed forms
def test_hemisphere_by_surface_integral_is_two_pi():
    omega = rad.solid_angle_surface(rad.cap_surface(ORIGIN, Z, 3.0, math.pi / 2), ORIGIN)
    assert omega == pytest.approx(rad.HEMISPHERE_SOLID_ANGLE, abs=1e-6)
    assert rad.HEMISPHERE_SOLID_ANGLE == pytest.approx(2 * math.pi)
    assert rad.SPHERE_SOLID_ANGLE == pytest.approx(4 * math.pi)


@pytest.mark.parametrize("alpha", [0.0, 0.1, 0.7, math.pi / 2, 2.5, math.pi])
def test_cap_matches_two_pi_one_minus_cos_and_surface_integral(alpha):
    omega = rad.solid_angle_cap(alpha)
    assert omega == pytest.approx(2 * math.pi * (1 - math.cos(alpha)), abs=1e-6)
    if alpha > 0:
        axis = np.array([0.3, -0.5, 0.8])
        numeric = rad.solid_angle_surface(rad.cap_surface(Z, axis, 2.0, alpha), Z)
        assert numeric == pytest.approx(omega, abs=1e-6)

        def sphere(theta, phi):  # the unit sphere in (θ, φ) directly: x = r̂, dS = sin θ r̂
            st = np.sin(theta)
            r_hat = np.stack([st * np.cos(phi), st * np.sin(phi), np.cos(theta)], axis=-1)
            return r_hat, st[..., None] * r_hat

        ranged = rad.solid_angle_surface(
            sphere, ORIGIN, u_range=(0.0, alpha), v_range=(0.0, 2 * math.pi)
        )
        assert ranged == pytest.approx(omega, abs=1e-6)


def test_cap_ends_are_hemisphere_and_sphere():
    assert rad.solid_angle_cap(math.pi / 2) == pytest.approx(2 * math.pi, abs=1e-12)
    assert rad.solid_angle_cap(math.pi) == pytest.approx(4 * math.pi, abs=1e-12)


@pytest.mark.parametrize(("radius", "distance"), [(1.0, 2.0), (0.01, 5.0), (3.0, 0.2), (1.0, 1e3)])
def test_disk_on_axis_closed_form(radius, distance):
    expected = 2 * math.pi * (1 - distance / math.sqrt(distance**2 + radius**2))
    assert rad.solid_angle_disk_on_axis(radius, distance) == pytest.approx(expected, rel=1e-6)
    general = rad.solid_angle_disk(ORIGIN, Z, radius, distance * Z)
    assert general == pytest.approx(expected, rel=1e-6)
    below = rad.solid_angle_disk(ORIGIN, Z, radius, -distance * Z)
    assert below == pytest.approx(expected, rel=1e-6)


def test_sphere_is_a_cap_and_four_pi_inside():
    center = np.array([0.3, -0.2, 0.5])
    for distance in (1.5, 4.0, 100.0):
        point = center + distance * np.array([0.6, 0.0, 0.8])
        alpha = math.asin(1.0 / distance)
        expected = rad.solid_angle_cap(alpha)
        assert rad.solid_angle_sphere(center, 1.0, point) == pytest.approx(expected, rel=1e-12)
    assert rad.solid_angle_sphere(center, 1.0, center + 0.5) == pytest.approx(4 * math.pi)


def test_square_on_axis_closed_form():
    # a square of side 2a seen from distance d on its axis: Ω = 4 asin(a²/(a² + d²))
    for a, d in [(1.0, 1.0), (0.5, 2.0), (2.0, 0.1)]:
        omega = rad.solid_angle_rectangle([-a, -a, 0], [2 * a, 0, 0], [0, 2 * a, 0], d * Z)
        assert omega == pytest.approx(4 * math.asin(a * a / (a * a + d * d)), rel=1e-12)


# --------------------------------------------------------------------------- disk off axis
@pytest.mark.parametrize(
    ("s", "h"),
    [
        (0.5, 1.0),
        (2.0, 1.0),
        (1.0, 0.1),
        (1.0, 0.01),
        (0.99, 0.01),
        (1.01, 0.01),
        (3.0, 0.5),
        (0.3, 1e-3),
        (0.999, 0.05),
    ],
)
def test_disk_off_axis_matches_quadrature_oracle(s, h):
    point = np.array([s * math.cos(0.7), s * math.sin(0.7), h])
    omega = rad.solid_angle_disk(ORIGIN, Z, 1.0, point)
    assert omega == pytest.approx(disk_oracle(1.0, s, h), abs=1e-10)


def test_disk_in_plane_outside_sees_nothing():
    assert rad.solid_angle_disk(ORIGIN, Z, 1.0, [2.0, 0.0, 0.0]) == pytest.approx(0.0, abs=1e-12)


# --------------------------------------------------------------------------- numerical integral
@pytest.mark.parametrize(
    "point", [[0.0, 0.0, 2.0], [0.7, -0.4, 0.5], [3.0, 1.0, 1.0], [0.2, 0.1, -0.8]]
)
def test_surface_integral_matches_disk(point):
    point = np.asarray(point)
    center, normal = np.array([0.1, 0.2, 0.0]), np.array([0.0, 0.0, 1.0])
    numeric = rad.solid_angle_surface(rad.disk_surface(center, normal, 1.0), point)
    exact = rad.solid_angle_disk(center, normal, 1.0, point)
    assert abs(numeric) == pytest.approx(exact, abs=1e-4)
    # oriented: positive when the normal points away from the observer
    assert np.sign(numeric) == np.sign(np.dot(center - point, normal))


@pytest.mark.parametrize("point", [[0.5, 0.5, 1.0], [2.0, -1.0, 0.3], [0.1, 0.9, -0.4]])
def test_surface_integral_matches_rectangle(point):
    corner, eu, ev = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.2]), np.array([0, 1.5, 0])
    point = np.asarray(point)
    numeric = rad.solid_angle_surface(rad.rectangle_surface(corner, eu, ev), point)
    exact = rad.solid_angle_rectangle(corner, eu, ev, point)
    assert abs(numeric) == pytest.approx(exact, abs=1e-4)


@pytest.mark.parametrize("point", [[0.2, 0.3, 0.7], [-1.0, 2.0, 0.5], [0.3, 0.3, -0.25]])
def test_surface_integral_matches_signed_triangle(point):
    a, b, c = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.1, 0.0]), np.array([0.2, 1.0, 0.3])
    point = np.asarray(point)
    numeric = rad.solid_angle_surface(rad.triangle_surface(a, b, c), point)
    assert numeric == pytest.approx(rad.solid_angle_triangle(a, b, c, point, signed=True), abs=1e-4)


# --------------------------------------------------------------------------- triangle, polygon
def test_triangle_matches_girard_area_of_spherical_triangle():
    rng = np.random.default_rng(3)
    a, b, c = rng.normal(size=(3, 50, 3)) + np.array([0.0, 0.0, 2.0])
    point = rng.normal(size=(50, 3)) * 0.3
    omega = rad.solid_angle_triangle(a, b, c, point)
    centroid = (a + b + c) / 3 - point
    pdf = square_to_spherical_triangle_pdf(centroid, a - point, b - point, c - point)
    np.testing.assert_allclose(omega, 1 / pdf, rtol=1e-9)


def test_triangle_orientation_and_large_angles():
    a, b, c = np.array([-1.0, -1, 0]), np.array([3.0, -1, 0]), np.array([-1.0, 3, 0])
    above = np.array([0.0, 0.0, 1e-3])  # nearly the full hemisphere: Ω > π
    omega = rad.solid_angle_triangle(a, b, c, above)
    assert math.pi < omega < 2 * math.pi
    assert rad.solid_angle_triangle(a, b, c, above, signed=True) == pytest.approx(-omega)
    assert rad.solid_angle_triangle(a, c, b, above, signed=True) == pytest.approx(omega)


def test_nonconvex_polygon_is_sum_of_its_parts():
    # an L shape = unit square [0,1]² + rectangle [1,2]×[0,1] + [0,1]×[1,2]
    polygon = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]], float)
    point = np.array([1.7, 1.6, 0.4])
    parts = sum(
        rad.solid_angle_rectangle(np.asarray(corner, float), [1, 0, 0], [0, 1, 0], point)
        for corner in ([0, 0, 0], [1, 0, 0], [0, 1, 0])
    )
    assert rad.solid_angle_polygon(polygon, point) == pytest.approx(parts, rel=1e-12)
    signed = rad.solid_angle_polygon(polygon, point, signed=True)
    assert rad.solid_angle_polygon(polygon[::-1], point, signed=True) == pytest.approx(-signed)
    # in its plane, in the notch outside the L: no solid angle and no error
    assert rad.solid_angle_polygon(polygon, [1.5, 1.5, 0.0]) == pytest.approx(0.0, abs=1e-12)


def test_small_patch_is_the_differential_solid_angle():
    center, normal = np.array([0.3, 0.1, 0.0]), np.array([0.0, 0.6, 0.8])
    point = np.array([0.5, -1.0, 2.0])
    s, t, _ = frame_from_normal(normal)
    for eps in (1e-2, 1e-3):
        corner = center - eps / 2 * (s + t)
        exact = rad.solid_angle_rectangle(corner, eps * s, eps * t, point)
        patch = rad.solid_angle_patch(center, normal, eps * eps, point)
        assert patch == pytest.approx(exact, rel=10 * eps**2)


# --------------------------------------------------------------------------- properties
coordinate = st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False)
vector = st.tuples(coordinate, coordinate, coordinate).map(np.array)


@settings(max_examples=60, deadline=None)
@given(a=vector, b=vector, c=vector, t=st.floats(0.05, 0.95), height=st.floats(0.2, 2.0))
def test_triangle_additivity_when_split(a, b, c, t, height):
    normal = np.cross(b - a, c - a)
    if np.linalg.norm(normal) < 1e-2:
        return
    point = (a + b + c) / 3 + height * normal / np.linalg.norm(normal) + np.array([0.3, -0.2, 0])
    if abs(np.dot(point - a, normal / np.linalg.norm(normal))) < 1e-2:
        return
    m = a + t * (b - a)  # split the edge ab
    whole = rad.solid_angle_triangle(a, b, c, point)
    halves = rad.solid_angle_triangle(a, m, c, point) + rad.solid_angle_triangle(m, b, c, point)
    assert halves == pytest.approx(whole, abs=1e-10)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), a=vector, b=vector, c=vector, point=vector)
def test_solid_angles_invariant_under_rotation(seed, a, b, c, point):
    rotation = Rotation.random(random_state=seed).as_matrix()
    point = point + np.array([0.0, 0.0, 5.0])  # above every shape (z ≤ 2.8)
    rot = lambda v: rotation @ v  # noqa: E731
    tri = rad.solid_angle_triangle(a, b, c, point)
    assert rad.solid_angle_triangle(rot(a), rot(b), rot(c), rot(point)) == pytest.approx(
        tri, abs=1e-10
    )
    normal = np.array([0.2, -0.3, 1.0])
    disk = rad.solid_angle_disk(a, normal, 0.8, point)
    assert rad.solid_angle_disk(rot(a), rot(normal), 0.8, rot(point)) == pytest.approx(
        disk, abs=1e-10
    )


# --------------------------------------------------------------------------- irradiance
def test_point_source_inverse_square_and_cosine():
    source = np.array([0.0, 0.0, 2.0])
    e = rad.irradiance_point_source([3.0, 1.5, 0.0], source, ORIGIN, Z)
    np.testing.assert_allclose(e, [0.75, 0.375, 0.0])
    far = rad.irradiance_point_source(3.0, 2 * source, ORIGIN, Z)
    assert far[0] == pytest.approx(e[0] / 4)
    theta = 0.6
    tilted = np.array([math.sin(theta), 0.0, math.cos(theta)])
    e_tilted = rad.irradiance_point_source(3.0, source, ORIGIN, tilted)
    assert e_tilted[0] == pytest.approx(e[0] * math.cos(theta))
    behind = rad.irradiance_point_source(3.0, source, ORIGIN, -Z)
    assert behind[0] == 0.0


def test_small_disk_source_is_a_point_source():
    # a Lambertian disk of radiance L and area A has intensity I = L A along its axis
    radius, distance, radiance = 1e-3, 2.0, 5.0
    disk = rad.irradiance_disk_source(radiance, radius, distance)
    point = rad.irradiance_point_source(radiance * math.pi * radius**2, distance * Z, ORIGIN, Z)
    assert disk[0] == pytest.approx(point[0], rel=1e-6)


@pytest.mark.parametrize("theta", [0.0, 0.4, 0.9, 1.2, 1.45, 1.7, 2.0])
def test_sphere_source_matches_monte_carlo(theta):
    # E = ∫_cone L max(cos θ, 0) dω, estimated with uniform cone samples (pdf 1/Ω)
    radiance, radius, center = 2.0, 0.8, np.array([0.0, 0.0, 1.6])
    normal = np.array([math.sin(theta), 0.0, math.cos(theta)])
    cos_alpha = math.sqrt(1 - (radius / 1.6) ** 2)
    u = np.random.default_rng(11).random((1 << 18, 2))
    w = to_world(square_to_uniform_cone(u, cos_alpha), frame_from_normal(Z))
    values = radiance * np.maximum(w @ normal, 0.0) * 2 * math.pi * (1 - cos_alpha)
    estimate, sigma = values.mean(), values.std() / math.sqrt(len(values))
    exact = rad.irradiance_sphere_source(radiance, center, radius, ORIGIN, normal)[0]
    assert abs(exact - estimate) <= 5 * sigma + 1e-12
    if theta == 0.0:
        assert exact == pytest.approx(math.pi * radiance * (radius / 1.6) ** 2, rel=1e-12)


@pytest.mark.parametrize(("offset", "distance"), [(0.0, 1.0), (0.5, 1.0), (2.0, 0.7), (1.0, 0.3)])
def test_disk_source_matches_area_quadrature(offset, distance):
    # E = L ∫_disk cos θ_r cos θ_s / r² dA, in polar coordinates about the disk centre
    radius, radiance = 1.0, 1.5

    def integrand(theta, r):
        d2 = distance**2 + r * r + offset**2 - 2 * r * offset * math.cos(theta)
        return radiance * distance**2 / d2**2 * r

    expected = integrate.dblquad(integrand, 0, radius, 0, 2 * math.pi, epsabs=1e-12)[0]
    e = rad.irradiance_disk_source(radiance, radius, distance, offset)
    assert e[0] == pytest.approx(expected, rel=1e-8)
    if offset == 0.0:
        sin2_alpha = radius**2 / (radius**2 + distance**2)
        assert e[0] == pytest.approx(math.pi * radiance * sin2_alpha, rel=1e-12)


# --------------------------------------------------------------------------- flux
def test_flux_uniform_radiance_hemisphere_and_wedge():
    sensor = rad.rectangle_surface([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.5, 0.5])
    area = np.linalg.norm(np.cross([2.0, 0.0, 0.0], [0.0, 0.5, 0.5]))

    def uniform(directions, points):
        return np.broadcast_to(np.array([1.0, 3.0]), (*directions.shape[:-1], 2))

    phi = rad.radiant_flux(uniform, sensor)
    np.testing.assert_allclose(phi, np.pi * area * np.array([1.0, 3.0]), rtol=1e-12)
    alpha = 0.4
    phi_wedge = rad.radiant_flux(uniform, sensor, alpha)
    np.testing.assert_allclose(phi_wedge, phi * math.sin(alpha) ** 2, rtol=1e-12)


def test_flux_of_directional_and_spatially_varying_radiance():
    sensor = rad.disk_surface([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 2.0)

    def radiance(directions, points):  # L = (1 + x) cos³θ about the normal z
        return ((1 + points[..., 0]) * directions[..., 2] ** 3)[..., None]

    # ∫ cos³θ cosθ dω = 2π/5, ∫_disk (1 + x) dA = π R²
    phi = rad.radiant_flux(radiance, sensor)
    assert phi[0] == pytest.approx(2 * math.pi / 5 * math.pi * 4.0, rel=1e-10)


def test_lambertian_emitter_relations_are_consistent():
    radiance, area = 2.5, 0.3
    # exitance M = ∫ L cos θ dω over the hemisphere, via the flux through the emitting patch
    sensor = rad.rectangle_surface([0.0, 0.0, 0.0], [area, 0.0, 0.0], [0.0, 1.0, 0.0])
    phi = rad.radiant_flux(lambda d, x: radiance + 0 * d[..., :1], sensor)
    exitance = phi[0] / area
    assert rad.radiance_from_exitance(exitance) == pytest.approx(radiance, rel=1e-12)
    # ∫ I(θ) dω over the hemisphere is the flux too: 2π ∫ L A cos θ sin θ dθ
    mu, w = np.polynomial.legendre.leggauss(16)
    cos_theta = 0.5 * (mu + 1)
    intensity = rad.intensity_lambertian(radiance, area, cos_theta)
    assert 2 * math.pi * np.sum(0.5 * w * intensity[:, 0]) == pytest.approx(phi[0], rel=1e-12)
    # lecture 14: L = J_o / |X| with J_o the intensity along the normal; and at any angle
    j_o = rad.intensity_lambertian(radiance, area, 1.0)
    assert rad.radiance_from_intensity(j_o, area)[0] == pytest.approx(radiance)
    back = rad.radiance_from_intensity(intensity, area, cos_theta)  # (16, 1): C = 1
    np.testing.assert_allclose(back[:, 0], radiance, rtol=1e-12)
    assert rad.intensity_lambertian(radiance, area, -0.5)[0] == 0.0


def test_radiance_across_interface_and_basic_radiance():
    radiance = np.array([1.0, 2.0, 4.0])
    into_glass = rad.radiance_across_interface(radiance, 1.0, 1.5)
    np.testing.assert_allclose(into_glass, radiance * 2.25)
    np.testing.assert_allclose(rad.radiance_across_interface(into_glass, 1.5, 1.0), radiance)
    np.testing.assert_allclose(
        rad.basic_radiance(into_glass, 1.5), rad.basic_radiance(radiance, 1.0)
    )


# --------------------------------------------------------------------------- backends
def test_backends_keep_dtype_and_values(backend):
    a, b, c = backend([0.0, 0.0, 0.0]), backend([1.0, 0.1, 0.0]), backend([0.2, 1.0, 0.3])
    point = backend([[0.2, 0.3, 0.7], [1.0, -1.0, 0.4]])
    results = {
        "triangle": rad.solid_angle_triangle(a, b, c, point),
        "disk": rad.solid_angle_disk(a, backend([0.0, 0.0, 1.0]), backend(1.0), point),
        "cap": rad.solid_angle_cap(backend([0.3, 1.0])),
        "surface": rad.solid_angle_surface(rad.triangle_surface(a, b, c), point),
        "sphere E": rad.irradiance_sphere_source(1.0, b + 2.0, backend(0.5), point, c),
    }
    reference = {
        "triangle": rad.solid_angle_triangle(*(to_numpy(v) for v in (a, b, c, point))),
        "disk": rad.solid_angle_disk(to_numpy(a), Z, 1.0, to_numpy(point)),
        "cap": rad.solid_angle_cap(np.array([0.3, 1.0])),
        "surface": rad.solid_angle_surface(
            rad.triangle_surface(*(to_numpy(v) for v in (a, b, c))), to_numpy(point)
        ),
        "sphere E": rad.irradiance_sphere_source(
            1.0, to_numpy(b) + 2.0, 0.5, to_numpy(point), to_numpy(c)
        ),
    }
    for name, value in results.items():
        assert type(value) is type(a), name
        assert value.dtype == a.dtype, name
        rtol = 1e-5 if "32" in str(a.dtype) else 1e-12
        np.testing.assert_allclose(to_numpy(value), reference[name], rtol=rtol, err_msg=name)


def test_torch_gradients_are_finite_and_right():
    torch = pytest.importorskip("torch")
    point = torch.tensor([0.2, 0.3, 0.7], dtype=torch.float64, requires_grad=True)
    a = torch.tensor([0.0, 0.0, 0.0], dtype=torch.float64, requires_grad=True)
    omega = rad.solid_angle_triangle(a, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], point)
    assert isinstance(omega, torch.Tensor)
    omega.backward()
    assert torch.isfinite(point.grad).all() and torch.isfinite(a.grad).all()
    # on the axis of a disk: dΩ/dd = −2π R² / (d² + R²)^{3/2}; s = 0 must not give NaN
    d = torch.tensor(2.0, dtype=torch.float64, requires_grad=True)
    radius = torch.tensor(1.0, dtype=torch.float64, requires_grad=True)
    zero = torch.zeros((), dtype=torch.float64)
    omega = rad.solid_angle_disk(
        [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius, torch.stack([zero, zero, d])
    )
    omega.backward()
    assert d.grad.item() == pytest.approx(-2 * math.pi / 5**1.5, rel=1e-10)
    assert radius.grad.item() == pytest.approx(2 * math.pi * 2.0 / 5**1.5, rel=1e-10)
    # off axis as well
    p = torch.tensor([0.9, 0.3, 0.05], dtype=torch.float64, requires_grad=True)
    rad.solid_angle_disk([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0, p).backward()
    assert torch.isfinite(p.grad).all()


def test_torch_float32_kept():
    torch = pytest.importorskip("torch")
    point = torch.tensor([0.1, 0.2, 1.0], dtype=torch.float32)
    omega = rad.solid_angle_disk([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0, point)
    assert omega.dtype == torch.float32
    assert rad.irradiance_point_source(1.0, point, [0.0, 0.0, 0.0], [0, 0, 1.0]).dtype == (
        torch.float32
    )


# --------------------------------------------------------------------------- bad input
def test_errors_name_the_argument():
    tri = (np.zeros(3), np.array([1.0, 0, 0]), np.array([0.0, 1, 0]))
    cases = [
        (lambda: rad.solid_angle_triangle(*tri, np.array([0.2, 0.2])), "point"),
        (lambda: rad.solid_angle_triangle(*tri, np.array([0.2, np.nan, 1.0])), "point"),
        (lambda: rad.solid_angle_triangle(*tri, np.array([0.2, 0.2, 0.0])), "triangle"),
        (lambda: rad.solid_angle_triangle(*tri, np.array([0.5, 0.0, 0.0])), "triangle"),
        (lambda: rad.solid_angle_triangle(*tri, np.array([1.0, 0.0, 0.0])), "triangle"),
        (lambda: rad.solid_angle_polygon(np.array(tri)[:2], Z), "vertices"),
        (lambda: rad.solid_angle_rectangle(ORIGIN, [1, 0, 0], [0, 1, 0], [0.5, 0.5, 0]), "rect"),
        (lambda: rad.solid_angle_disk(ORIGIN, Z, 1.0, [0.3, 0.4, 0.0]), "disk"),
        (lambda: rad.solid_angle_disk(ORIGIN, Z, 1.0, [1.0, 0.0, 0.0]), "disk"),
        (lambda: rad.solid_angle_disk(ORIGIN, Z, 0.0, Z), "radius"),
        (lambda: rad.solid_angle_disk(ORIGIN, Z, 1.0, Z, order=0), "order"),
        (lambda: rad.solid_angle_disk_on_axis(-1.0, 1.0), "radius"),
        (lambda: rad.solid_angle_disk_on_axis(1.0, 0.0), "distance"),
        (lambda: rad.solid_angle_cap(-0.1), "half_angle"),
        (lambda: rad.solid_angle_sphere(ORIGIN, 1.0, [0.0, 1.0, 0.0]), "sphere"),
        (lambda: rad.solid_angle_patch(ORIGIN, Z, 0.0, Z), "area"),
        (lambda: rad.solid_angle_patch(ORIGIN, Z, 1.0, ORIGIN), "point"),
        (
            lambda: rad.solid_angle_surface(rad.disk_surface(ORIGIN, Z, 1.0), [0, 0, np.inf]),
            "point",
        ),
        (lambda: rad.irradiance_point_source(1.0, Z, Z, Z), "point"),
        (lambda: rad.irradiance_sphere_source(1.0, Z, 2.0, ORIGIN, Z), "point"),
        (lambda: rad.irradiance_disk_source(1.0, 1.0, 1.0, -1.0), "offset"),
        (lambda: rad.radiant_flux(lambda d, x: d, rad.disk_surface(ORIGIN, Z, 1.0), 2.0), "half"),
        (lambda: rad.radiance_from_intensity(1.0, 1.0, 0.0), "cos_theta"),
        (lambda: rad.radiance_from_intensity(1.0, -1.0), "area"),
        (lambda: rad.intensity_lambertian(1.0, 1.0, 1.5), "cos_theta"),
        (lambda: rad.radiance_across_interface(1.0, 0.0, 1.5), "eta_from"),
        (lambda: rad.basic_radiance(1.0, -1.33), "eta"),
        (lambda: rad.radiance_from_exitance(np.nan), "exitance"),
    ]
    for call, word in cases:
        with pytest.raises(ValueError, match=word):
            call()
