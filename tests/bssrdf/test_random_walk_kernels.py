"""The compiled random walk (bssrdf/_random_walk_kernels.py) against the NumPy code it mirrors
(bssrdf/random_walk.py and the functions it calls): the same numbers on the same inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("numba")

import numba

from brdfkit import sampling
from brdfkit.bssrdf._random_walk_kernels import kernels, walk_kernel
from brdfkit.bssrdf.medium import sample_henyey_greenstein
from brdfkit.bssrdf.random_walk import entry, uniforms, walk_reference
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.geometry import frame_from_normal, to_world


@pytest.fixture(scope="module")
def compiled():
    return kernels()


def test_uniforms_are_the_hash_of_seed_and_slot(compiled):
    uniform = compiled["uniform"]
    seeds = sampling.query_seeds(7, 50)
    slots = np.arange(50) * 3 + 1

    @numba.njit
    def each(seeds, slots, out):
        for i in range(seeds.shape[0]):
            out[i] = uniform(seeds[i], slots[i])

    out = np.empty(50)
    each(seeds, slots, out)
    np.testing.assert_array_equal(out, uniforms(seeds, slots))
    assert np.all((out > 0) & (out < 1))


@pytest.mark.parametrize("eta", [1.0, 1.33, 1.5, 0.8])
def test_fresnel_inside_is_fresnel_dielectric_from_inside(compiled, eta):
    fresnel_inside = compiled["fresnel_inside"]
    cosines = np.concatenate([[0.0, 1.0], np.random.default_rng(1).random(300)])
    kernel = np.array([fresnel_inside(c, eta) for c in cosines])
    np.testing.assert_allclose(kernel, fresnel_dielectric(-cosines, eta), rtol=1e-15, atol=0)


@pytest.mark.parametrize("g", [0.0, 5e-4, -0.6, 0.85])
def test_scattering_cosine_is_the_henyey_greenstein_sampler(compiled, g):
    u = np.random.default_rng(2).random(300)
    kernel = np.array([compiled["scattering_cosine"](v, g) for v in u])
    np.testing.assert_array_equal(kernel, sample_henyey_greenstein(u, g))


def test_scatter_is_the_frame_and_its_rotation(compiled):
    rng = np.random.default_rng(3)
    d = rng.normal(size=(200, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:2] = [[0, 0, 1], [0, 0, -1]]
    cos_theta, phi = rng.uniform(-1, 1, 200), rng.uniform(0, 2 * math.pi, 200)
    kernel = np.array(
        [compiled["scatter"](*v, c, p) for v, c, p in zip(d, cos_theta, phi, strict=True)]
    )
    sin_theta = np.sqrt(1 - cos_theta**2)
    local = np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], -1)
    np.testing.assert_allclose(kernel, to_world(local, frame_from_normal(d)), atol=1e-15)


@pytest.mark.parametrize(
    ("albedo", "eta", "g", "thickness", "cos_theta_i"),
    [(0.9, 1.4, 0.5, 3.0, 0.8), (0.99, 1.0, 0.0, math.inf, 1.0), (0.6, 1.5, -0.3, 0.5, 0.3)],
)
def test_walks_are_the_reference_walk_for_walk(albedo, eta, g, thickness, cos_theta_i):
    seeds = sampling.query_seeds(11, 600)
    _, direction = entry(cos_theta_i, eta)
    side, radius, events = walk_kernel(seeds, albedo, eta, g, thickness, direction, 10_000)
    ref_side, ref_radius, ref_events = walk_reference(
        seeds, albedo, eta, g, thickness, direction, 10_000
    )
    np.testing.assert_array_equal(side, ref_side)
    np.testing.assert_array_equal(events, ref_events)
    np.testing.assert_allclose(radius, ref_radius, rtol=1e-12, atol=1e-12)
    assert len(np.unique(side)) >= 2  # the walks end in more than one way
