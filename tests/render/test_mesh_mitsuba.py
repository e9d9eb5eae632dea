"""Meshes with shadows: brdfkit and Mitsuba 3 (``scalar_rgb``, ``direct``) agree.

A torus over a ground plane (self- and cast shadows) and an icosphere on it, 64×48 pixels,
seen by the same look-at camera (40° horizontal) under a small environment map in Mitsuba's
orientation plus a directional light. brdfkit renders 4×4 shading points per pixel (Mitsuba's
box filter); both take enough samples that each image's own noise (1-1.5 % relative RMSE
after the blur, measured against 8192-spp Mitsuba) stays inside the bounds: mean within 1 %,
relative RMSE of the images blurred by a Gaussian of one pixel ≤ 3 %.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.ndimage import gaussian_filter

from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.interop import mitsuba as ms
from brdfkit.interop import to_mitsuba_dict
from brdfkit.light import DirectionalLight, EnvironmentMap
from brdfkit.render.mesh import MeshScene, render_mesh, torus_over_plane
from brdfkit.render.mitsuba_frame import MITSUBA_ENVMAP_ROTATION, look_at_camera

pytestmark = [pytest.mark.slow, pytest.mark.oracle]

SIZE = (48, 64)
LOOK_AT = ((0.0, 2.2, 3.2), (0.0, 0.4, 0.0), (0.0, 1.0, 0.0))
FOV = 40.0
MITSUBA_SPP = 256
SUPERSAMPLE = 4
BRDFKIT_SPP = 8  # per shading point: 16 × 8 = 128 per pixel and strategy
SUN = DirectionalLight((0.5, 1.0, 0.3), irradiance=3.0)


@pytest.fixture(scope="module")
def mitsuba():
    pytest.importorskip("mitsuba", reason="Mitsuba 3 (the oracle extra) is not installed")
    try:
        mi, _ = ms.load_mitsuba(("scalar_rgb",))
    except ImportError as error:
        pytest.skip(str(error))
    return mi


def _sky() -> EnvironmentMap:
    """A small smooth map, bluish, bright at the zenith and towards φ = 0, so that its
    orientation shows (smooth: Mitsuba's texel nodes interpolate it as brdfkit's do)."""
    theta = (np.arange(16) + 0.5) * np.pi / 16
    phi = (np.arange(32) + 0.5) * np.pi / 16
    t, p = np.meshgrid(theta, phi, indexing="ij")
    base = 0.5 + 0.4 * np.cos(t) + 0.3 * np.cos(p) * np.sin(t)
    image = base[..., None] * np.array([0.8, 0.9, 1.1])
    return EnvironmentMap(image, rotation=MITSUBA_ENVMAP_ROTATION)


def _sphere_on_plane() -> trimesh.Trimesh:
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    ball.apply_translation([0.3, 0.5, 0.0])
    plane = torus_over_plane(sections=4)  # keep only its ground square
    ground = trimesh.Trimesh(plane.vertices[-4:], plane.faces[-2:] - (len(plane.vertices) - 4))
    return trimesh.util.concatenate([ball, ground])


def _gold() -> tuple[RoughConductor, dict]:
    brdf = RoughConductor(alpha=0.3, material="Au", masking="smith_separable")
    return brdf, to_mitsuba_dict(brdf)


def _clay() -> tuple[Lambertian, dict]:
    brdf = Lambertian(np.array([0.6, 0.5, 0.4]))
    return brdf, to_mitsuba_dict(brdf)


CASES = {"torus-clay": (torus_over_plane, _clay), "sphere-gold": (_sphere_on_plane, _gold)}


@pytest.mark.parametrize("case", list(CASES))
def test_mesh_renders_agree_with_mitsuba(case, mitsuba, tmp_path):
    make_mesh, make_brdf = CASES[case]
    path = tmp_path / "scene.ply"
    make_mesh().export(path, vertex_normal=True)  # both read the same normals
    brdf, bsdf = make_brdf()
    env = _sky()
    emitters = {"sky": ms.envmap_emitter(mitsuba, env), "sun": ms.directional_emitter(SUN)}
    mi_scene = ms.mesh_scene(mitsuba, path, bsdf, emitters, LOOK_AT, FOV, SIZE)
    reference = ms.render(mitsuba, mi_scene, MITSUBA_SPP)
    camera = look_at_camera(*LOOK_AT, fov=FOV, size=SIZE)
    image = render_mesh(
        MeshScene.from_file(path), brdf, [env, SUN], camera, SIZE, supersample=SUPERSAMPLE,
        samples=BRDFKIT_SPP,
    )  # fmt: skip
    mean_ratio = image.mean() / reference.mean()
    assert abs(mean_ratio - 1) < 0.01, f"{case}: mean ratio {mean_ratio:.4f} to Mitsuba"
    blurred, ref = (gaussian_filter(x, (1, 1, 0)) for x in (image, reference))
    error = ms.relative_rmse(blurred, ref, np.ones(SIZE, dtype=bool))
    assert error < 0.03, f"{case}: relative RMSE {error:.4f} of the blurred images"
