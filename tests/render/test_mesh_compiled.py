"""Meshes on the compiled path: the tile kernel records each sample, Embree answers the
shadow rays in between, and the image equals the NumPy mesh path's for the same seeds."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.light import DirectionalLight, EnvironmentMap
from brdfkit.render import reflected_radiance, shade
from brdfkit.render.compiled_shading import SHADOW_SAMPLES, EnvironmentShader
from brdfkit.render.mesh import MeshScene, torus_over_plane
from brdfkit.render.mitsuba_frame import look_at_camera

pytest.importorskip("numba", reason="the compiled path needs numba")
pytest.importorskip("embreex", reason="shadow rays need Embree (the mesh extra)")

GOLD = RoughConductor(alpha=0.2, material="Au", masking="smith_separable")
SIZE = (6, 8)


def _map() -> EnvironmentMap:
    """A small peaked map (bright texels and dark ones)."""
    image = np.random.default_rng(1).random((16, 32, 3)) ** 4 * 5
    return EnvironmentMap(image, scale=1.5)


@pytest.fixture(scope="module")
def torus():
    """A coarse torus over the ground seen from above and in front: self- and cast shadows
    in most pixels, the G-buffer and its visibility factor."""
    scene = MeshScene.from_trimesh(torus_over_plane(sections=10))
    camera = look_at_camera((0.0, 2.2, 3.2), (0.0, 0.4, 0.0), (0.0, 1.0, 0.0), 40.0, SIZE)
    g = scene.gbuffer(camera, SIZE)
    return g, scene.visibility(g)


@pytest.mark.parametrize("sequence", ["sobol", "random"])
def test_compiled_float64_mesh_render_equals_the_numpy_path(torus, sequence):
    g, visibility = torus
    lights = [_map(), DirectionalLight((0.5, 1.0, 0.3), irradiance=3.0)]
    options = {"samples": 8, "seed": 4, "sequence": sequence, "visibility": visibility}
    expected = shade(g, GOLD, lights, **options, compiled=False)
    image = shade(g, GOLD, lights, **options, compiled="float64")
    np.testing.assert_allclose(image, expected, rtol=1e-10, atol=1e-12)
    unshadowed = shade(g, GOLD, lights, samples=8, seed=4, sequence=sequence, compiled=False)
    assert np.abs(unshadowed - expected).max() > 0.1 * expected.max()  # shadows are there


def test_chunks_of_samples_keep_the_value_and_its_standard_error(torus):
    """More samples than one chunk of shadow rays: per-pixel mean and standard error as
    :func:`~brdfkit.render.reflected_radiance` with the visibility factor."""
    g, visibility = torus
    env, rows = _map(), slice(None)
    samples = SHADOW_SAMPLES + 5
    query = (g.wo, g.normals, g.points, g.tangents)
    options = {"samples": samples, "seed": 9, "sequence": "sobol"}
    expected = reflected_radiance(
        GOLD, env, *query, method="mis", **options, visibility=visibility(rows)
    )
    shader = EnvironmentShader(GOLD, env, method="mis", dtype=np.float64)
    estimate = shader.shade(
        shader.prepare(*query, mask=g.mask), **options, visibility=visibility(rows)
    )
    m = g.mask
    np.testing.assert_allclose(estimate.value[m], expected.value[m], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(estimate.stderr[m], expected.stderr[m], rtol=1e-8, atol=1e-12)


def test_exact_parts_and_visibility_are_refused_together(torus):
    g, visibility = torus
    shader = EnvironmentShader(Lambertian(0.3), _map(), method="auto")  # ρE(n)/π: no shadows
    prepared = shader.prepare(g.wo, g.normals, g.points, g.tangents, mask=g.mask)
    with pytest.raises(ValueError, match="mis"):
        shader.shade(prepared, samples=1, visibility=visibility(slice(None)))
