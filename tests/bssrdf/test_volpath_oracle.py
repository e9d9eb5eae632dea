"""The random walk against Mitsuba 3's ``volpath``: a thick slab's total reflectance
(``benchmarks/bench_bssrdf.py`` also compares its radial profile and a translucent sphere)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.bssrdf import tally_walks
from brdfkit.fresnel import fresnel_dielectric

ALBEDO, ETA, DEPTH = 0.9, 1.33, 20.0


def test_a_thick_slab_reflects_as_mitsuba_volpath_says():
    """Under a constant unit sky, seen at normal incidence, the slab's radiance is by reciprocity
    its total reflectance at normal incidence: the walk's diffuse part plus the specular F(1)."""
    pytest.importorskip("mitsuba", reason="Mitsuba 3 (the oracle extra) is not installed")
    from brdfkit.interop import mitsuba as ms

    try:
        mi, _ = ms.load_mitsuba(("llvm_ad_rgb",))
    except ImportError as error:
        pytest.skip(f"no Mitsuba llvm variant: {error}")
    transform = mi.ScalarTransform4f()
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": -1},
            "sensor": {
                "type": "orthographic",
                "to_world": transform.look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
                @ transform.scale([0.01, 0.01, 1]),
                "film": {"type": "hdrfilm", "width": 32, "height": 32, "rfilter": {"type": "box"}},
                "sampler": {"type": "independent"},
            },
            "light": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
            "slab": {  # 40 × 40 × 20 mean free paths, its top face at z = 0
                "type": "cube",
                "to_world": transform.translate([0, 0, -DEPTH / 2])
                @ transform.scale([20, 20, DEPTH / 2]),
                "bsdf": {"type": "dielectric", "int_ior": ETA, "ext_ior": 1.0},
                "interior": {
                    "type": "homogeneous",
                    "albedo": {"type": "rgb", "value": ALBEDO},
                    "sigma_t": 1.0,
                    "phase": {"type": "isotropic"},
                },
            },
        }
    )
    pixels = ms.render(mi, scene, 128, seed=1)[..., 0].ravel()  # each pixel its own mean
    mitsuba, mitsuba_stderr = pixels.mean(), pixels.std(ddof=1) / math.sqrt(pixels.size)
    walk, walk_stderr = tally_walks(
        ALBEDO, ETA, 1.0, 200_000, seed=2, thickness=DEPTH
    ).reflectance()
    walk += float(fresnel_dielectric(1.0, ETA))
    combined = math.hypot(mitsuba_stderr, walk_stderr)
    assert combined < 0.006 * walk  # a few tenths of a percent: small counts, a few seconds
    assert abs(mitsuba - walk) < 3 * combined
    assert abs(mitsuba - walk) < 0.01 * walk
    assert np.all(np.isfinite(pixels))
