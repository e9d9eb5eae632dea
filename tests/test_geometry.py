"""Geometry: frames, spherical coordinates, reflection, refraction and half/difference angles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from brdfkit.geometry import (
    cartesian_to_spherical,
    critical_angle,
    frame_from_normal,
    from_half_diff,
    half_vector,
    reflect,
    refract,
    spherical_to_cartesian,
    to_half_diff,
    to_isotropic,
    to_local,
    to_world,
)


def upper_directions(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 1e-3
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


angles = st.tuples(
    st.floats(0.01, math.pi / 2 - 0.01),
    st.floats(-math.pi, math.pi),
    st.floats(0.01, math.pi / 2 - 0.01),
    st.floats(-math.pi, math.pi),
)


@given(angles)
@settings(max_examples=200, deadline=None)
def test_half_diff_round_trip_property(a):
    theta_i, phi_i, theta_o, phi_o = a
    wi = spherical_to_cartesian(np.array(theta_i), np.array(phi_i))
    wo = spherical_to_cartesian(np.array(theta_o), np.array(phi_o))
    back_i, back_o = from_half_diff(*to_half_diff(wi, wo))
    np.testing.assert_allclose(back_i, wi, atol=1e-6)
    np.testing.assert_allclose(back_o, wo, atol=1e-6)


def test_half_diff_round_trip_batch(backend):
    wi, wo = upper_directions(2000, 1), upper_directions(2000, 2)
    th, ph, td, pd = to_half_diff(backend(wi), backend(wo))
    back_i, back_o = from_half_diff(th, ph, td, pd)
    tol = 1e-6 if np.asarray(wi).dtype == np.float64 and "32" not in str(th.dtype) else 2e-5
    np.testing.assert_allclose(np.asarray(back_i), wi, atol=tol)
    np.testing.assert_allclose(np.asarray(back_o), wo, atol=tol)
    assert th.dtype == backend(wi).dtype
    assert np.all(np.asarray(th) <= math.pi / 2 + 1e-6)


def test_half_diff_of_mirror_pair_has_zero_theta_h():
    wo = upper_directions(100)
    theta_h, _, theta_d, _ = to_half_diff(reflect(wo), wo)
    np.testing.assert_allclose(theta_h, 0, atol=1e-7)
    np.testing.assert_allclose(theta_d, np.arccos(wo[:, 2]), atol=1e-7)


@given(arrays(np.float64, 3, elements=st.floats(-1, 1)).filter(lambda v: np.linalg.norm(v) > 0.1))
@settings(max_examples=200, deadline=None)
def test_frame_is_orthonormal_and_right_handed(n):
    s, t, nn = frame_from_normal(n)
    basis = np.stack([s, t, nn])
    np.testing.assert_allclose(basis @ basis.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.cross(nn, s), t, atol=1e-12)
    np.testing.assert_allclose(nn, n / np.linalg.norm(n), atol=1e-12)


def test_frame_with_tangent_and_local_world_round_trip():
    n = upper_directions(50)
    tangent = np.tile([1.0, 0.2, 0.0], (50, 1))
    frame = frame_from_normal(n, tangent)
    v = upper_directions(50, 3)
    np.testing.assert_allclose(to_world(to_local(v, frame), frame), v, atol=1e-12)
    np.testing.assert_allclose(to_local(n, frame), np.tile([0, 0, 1.0], (50, 1)), atol=1e-12)
    with pytest.raises(ValueError, match="tangent"):
        frame_from_normal(np.array([0, 0, 1.0]), np.array([0, 0, 2.0]))


@given(st.floats(0, math.pi), st.floats(-math.pi + 1e-9, math.pi))
@settings(max_examples=200, deadline=None)
def test_spherical_round_trip(theta, phi):
    v = spherical_to_cartesian(np.array(theta), np.array(phi))
    assert abs(np.linalg.norm(v) - 1) < 1e-12
    t2, p2 = cartesian_to_spherical(v)
    assert abs(float(t2) - theta) < 1e-6
    if 1e-6 < theta < math.pi - 1e-6:
        assert abs(math.remainder(float(p2) - phi, 2 * math.pi)) < 1e-6


@pytest.mark.parametrize("theta", [1e-12, 1e-9, 1e-5, math.pi - 1e-9])
def test_spherical_theta_is_exact_near_the_poles(theta):
    # acos(cos θ) cannot resolve θ below ~1e-8 (cos θ rounds to 1); atan2(sin θ, cos θ) can.
    v = np.array(
        [math.sin(theta) * math.cos(0.3), math.sin(theta) * math.sin(0.3), math.cos(theta)]
    )
    t, p = cartesian_to_spherical(v)
    assert float(t) == pytest.approx(theta, rel=1e-14)
    assert float(p) == pytest.approx(0.3, rel=1e-14)
    t2, _ = cartesian_to_spherical(3.0 * v)  # scale-invariant: no normalisation needed
    assert float(t2) == pytest.approx(theta, rel=1e-14)


def test_spherical_theta_gradient_is_finite_at_the_pole():
    torch = pytest.importorskip("torch")
    v = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64, requires_grad=True)
    theta, _ = cartesian_to_spherical(v)
    theta.backward()
    assert torch.isfinite(v.grad).all()
    w = torch.tensor([0.6, 0.0, 0.8], dtype=torch.float64, requires_grad=True)
    theta, _ = cartesian_to_spherical(w)
    theta.backward()  # dθ/dv = (cos θ cos φ, cos θ sin φ, −sin θ) for a unit v
    np.testing.assert_allclose(w.grad.numpy(), [0.8, 0.0, -0.6], rtol=1e-14)


def test_reflect_about_normal_and_default():
    w = upper_directions(100)
    np.testing.assert_allclose(reflect(w), reflect(w, np.array([0.0, 0.0, 1.0])), atol=1e-15)
    r = reflect(w)
    np.testing.assert_allclose(half_vector(w, r), np.tile([0, 0, 1.0], (100, 1)), atol=1e-12)


@given(st.floats(0.0, math.pi / 2 - 1e-3), st.floats(-math.pi, math.pi), st.floats(1.01, 3.0))
@settings(max_examples=200, deadline=None)
def test_refract_obeys_snell_and_tangential_momentum(theta, phi, eta):
    w = spherical_to_cartesian(np.array(theta), np.array(phi))
    w_t, valid = refract(w, eta)
    assert bool(valid)
    assert w_t[2] < 0 and abs(np.linalg.norm(w_t) - 1) < 1e-12
    sin_i = math.sin(theta)
    sin_t = math.hypot(w_t[0], w_t[1])
    assert abs(sin_i - eta * sin_t) < 1e-9  # Snell: η_i sinθi = η_t sinθt with η_i = 1
    np.testing.assert_allclose(eta * w_t[:2], -w[:2], atol=1e-9)  # tangential momentum
    back, ok = refract(w_t, eta)  # leaving the dense side retraces the path
    assert bool(ok)
    np.testing.assert_allclose(back, w, atol=1e-9)


def test_total_internal_reflection_beyond_critical_angle():
    eta = 1.5
    theta_c = float(critical_angle(eta))
    assert abs(theta_c - math.asin(1 / 1.5)) < 1e-15
    below = spherical_to_cartesian(np.array([theta_c - 1e-3, theta_c + 1e-3]), np.array([0.3, 0.3]))
    below[:, 2] *= -1  # inside the dielectric
    w_t, valid = refract(below, eta)
    assert valid.tolist() == [True, False]
    np.testing.assert_array_equal(w_t[1], 0)


def test_refract_gradients_flow_in_torch():
    torch = pytest.importorskip("torch")
    w = torch.tensor(upper_directions(10), requires_grad=True)
    eta = torch.tensor(1.33, dtype=torch.float64, requires_grad=True)
    w_t, valid = refract(w, eta)
    assert isinstance(w_t, torch.Tensor) and bool(valid.all())
    w_t[..., 2].sum().backward()
    assert torch.isfinite(w.grad).all() and torch.isfinite(eta.grad) and eta.grad != 0


def test_float32_is_kept():
    w = upper_directions(10).astype(np.float32)
    assert reflect(w).dtype == np.float32
    assert refract(w, 1.5)[0].dtype == np.float32
    assert to_half_diff(w, w[::-1])[0].dtype == np.float32
    assert frame_from_normal(w)[0].dtype == np.float32


def test_isotropic_reduction_is_rotation_invariant():
    wi, wo = upper_directions(100, 4), upper_directions(100, 5)
    angle = 0.7
    rot = np.array(
        [[math.cos(angle), -math.sin(angle), 0], [math.sin(angle), math.cos(angle), 0], [0, 0, 1]]
    )
    a = np.stack(to_isotropic(wi, wo))
    b = np.stack(to_isotropic(wi @ rot.T, wo @ rot.T))
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert np.all((a[2] >= 0) & (a[2] <= math.pi))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: reflect(np.zeros((4, 2))), "w must have a last axis of length 3"),
        (lambda: refract(np.array([0, 0, 1.0]), 0.0), r"eta must be in \(0\.0, inf\]; got 0"),
        (lambda: refract(np.array([0, 0, 1.0]), -1.5), r"eta must be in \(0\.0, inf\]; got -1\.5"),
        (lambda: refract(np.array([np.nan, 0, 1.0]), 1.5), "w must be finite"),
        (
            lambda: to_half_diff(np.array([0, 0, 1.0]), np.array([0, np.inf, 1.0])),
            "wo must be finite",
        ),
        (lambda: critical_angle(0.5), r"eta must be in \[1\.0, inf\]; got 0\.5"),
    ],
)
def test_bad_input_names_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()
