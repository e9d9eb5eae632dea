"""Converged renders of brdfkit and Mitsuba 3 (``scalar_rgb``, ``direct``) agree.

The scenes are the benchmark's gold and plastic spheres
(:func:`brdfkit.interop.mitsuba.benchmark_scenes`) at 16² pixels. Mitsuba averages jittered
positions inside each pixel (box filter), so brdfkit renders 4×4 sub-pixels per pixel and
averages them. Both take enough samples that each image's own noise is a few tenths of a
percent relative RMSE, well inside the 1 % bound.
"""

from __future__ import annotations

import pytest

from brdfkit.interop import mitsuba as ms
from brdfkit.light import EnvironmentMap
from brdfkit.render import interior_mask, render_sphere

pytestmark = [pytest.mark.slow, pytest.mark.oracle]

PIXELS = 16
SUPERSAMPLING = 4
MITSUBA_SPP = 65536
BRDFKIT_SPP = 4096  # per sub-pixel: 16 × 4096 = 65536 per pixel
SCENES = {scene.name: scene for scene in ms.benchmark_scenes(tabulated=False)}


@pytest.fixture(scope="module")
def mitsuba():
    pytest.importorskip("mitsuba", reason="Mitsuba 3 (the oracle extra) is not installed")
    try:
        mi, _ = ms.load_mitsuba(("scalar_rgb",))
    except ImportError as error:
        pytest.skip(str(error))
    return mi


@pytest.mark.parametrize("name", list(SCENES))
def test_converged_images_agree_with_mitsuba(name, mitsuba, shared_data):
    scene = SCENES[name]
    env = EnvironmentMap.from_file(shared_data / "envmaps" / "polyhaven" / scene.envmap)
    mi_scene = ms.sphere_scene(mitsuba, scene.mitsuba_bsdf, env, PIXELS)
    reference = ms.render(mitsuba, mi_scene, MITSUBA_SPP)
    s = SUPERSAMPLING
    fine = render_sphere(scene.brdf, env, resolution=PIXELS * s, samples=BRDFKIT_SPP)
    image = fine.reshape(PIXELS, s, PIXELS, s, -1).mean(axis=(1, 3))
    error = ms.relative_rmse(image, reference, interior_mask(PIXELS, margin=0.1))
    assert error < 0.01, f"{name}: relative RMSE {error:.4f} against Mitsuba"
