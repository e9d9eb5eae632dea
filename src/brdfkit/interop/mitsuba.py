r"""Mitsuba 3 scenes that see exactly what :func:`brdfkit.render.render_sphere` sees.

The oracle and benchmark peer for rendering: a unit sphere at the origin, seen by brdfkit's
default orthographic camera, under an :class:`~brdfkit.light.EnvironmentMap`, lit by
Mitsuba's ``direct`` integrator (one BSDF and one emitter sample per pixel sample, combined by
the power heuristic, as :func:`brdfkit.render.reflected_radiance`'s ``"mis"``).

Conventions matched (Mitsuba 3 ``src/emitters/envmap.cpp`` and ``src/sensors/orthographic.cpp``):

- **Map directions.** Mitsuba's envmap reads texel ``(u, v) = (φ/2π, θ/π)`` in its local frame
  as :math:`d_{mi} = (\sin\theta\sin\phi, \cos\theta, -\sin\theta\cos\phi)` (pole +y); brdfkit's
  as :math:`d = (\sin\theta\cos\phi, \sin\theta\sin\phi, \cos\theta)` (pole +z), then
  ``rotation`` ``R``. With :math:`d_{mi} = P d`, :math:`P = [[0,1,0],[0,0,1],[-1,0,0]]`, the
  emitter's ``to_world`` is :math:`R P^\top`.
- **Texel positions.** Both put column ``c`` at :math:`\phi = 2\pi (c + ½)/W`; Mitsuba puts row
  ``r`` at :math:`\theta = \pi r/(H - 1)` (poles on the first and last rows), brdfkit at
  :math:`\pi (r + ½)/H`. Mitsuba is therefore given brdfkit's bilinear map resampled at its own
  nodes, not the file.
- **Camera.** ``look_at(origin=(10, 0, 0), target=0, up=+z)`` makes Mitsuba's film right +y and
  up +z, brdfkit's :data:`brdfkit.render.scene.FRONT`; an orthographic sensor spans [−1, 1] across a
  square film, brdfkit's ``extent=2``. Mitsuba jitters positions inside each pixel (box filter)
  where brdfkit shades the pixel centre: the images agree away from the silhouette
  (:func:`interior_mask`).

References
----------
.. [1] W. Jakob, S. Speierer, N. Roussel et al., "Mitsuba 3 renderer", 2022,
       https://mitsuba-renderer.org (plugins ``envmap``, ``orthographic``, ``direct``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.brdf import BRDF, Lambertian, RoughConductor
from brdfkit.errors import require_extra
from brdfkit.interop.mitsuba_export import to_mitsuba_dict
from brdfkit.light.analytic import DirectionalLight
from brdfkit.light.environment import EnvironmentMap
from brdfkit.render.mitsuba_frame import MITSUBA_ENVMAP_ROTATION

LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
"""Dr.Jit's llvm variants need LLVM ≥ 16 (``benchmarks/setup.sh`` installs 19)."""

MAP_TO_MITSUBA = MITSUBA_ENVMAP_ROTATION
"""P: brdfkit map directions (pole +z) to Mitsuba envmap-local ones (pole +y)."""


@dataclass(frozen=True)
class Scene:
    """One benchmark scene: brdfkit's model, Mitsuba's BSDF dict and the map's file name."""

    name: str
    brdf: BRDF
    mitsuba_bsdf: dict[str, Any]
    envmap: str


def benchmark_scenes(tabulated: bool = True) -> list[Scene]:
    """The scenes of ``benchmarks/bench_render.py``, each brdfkit's model and Mitsuba's twin.

    - ``gold``: GGX α = 0.2 gold, separable Smith masking (Mitsuba's ``roughconductor``),
      under Poly Haven's ``royal_esplanade_1k``;
    - ``plastic``: Lambertian ρ = (0.5, 0.1, 0.1) + GGX α = 0.1 with a dielectric Fresnel
      (η = 1.5, k = 0) under ``studio_small_03_1k``; Mitsuba has no sum of BSDFs, so it gets
      the exporter's ``blendbsdf`` of the two lobes, each divided by its chance;
    - ``tabulated`` (with ``tabulated=True``; it takes seconds to build): a MERL-layout
      :class:`~brdfkit.measured.TabulatedBRDF` (90×90×180) of GGX α = 0.3 copper under
      ``royal_esplanade_1k``. Mitsuba 3 has no MERL plugin: it renders the analytic copper.
    """

    gold = RoughConductor(alpha=0.2, material="Au", masking="smith_separable")
    plastic = Lambertian([0.5, 0.1, 0.1]) + RoughConductor(
        alpha=0.1, eta=1.5, k=0.0, masking="smith_separable"
    )
    scenes = [
        Scene("gold", gold, to_mitsuba_dict(gold), "royal_esplanade_1k.hdr"),
        Scene("plastic", plastic, to_mitsuba_dict(plastic), "studio_small_03_1k.hdr"),
    ]
    if tabulated:
        from brdfkit.measured import TabulatedBRDF

        copper = RoughConductor(alpha=0.3, material="Cu", masking="smith_separable")
        table = TabulatedBRDF.from_brdf(copper, (90, 90, 180), channels=3)
        scenes.append(Scene("tabulated", table, to_mitsuba_dict(copper), "royal_esplanade_1k.hdr"))
    return scenes


def load_mitsuba(variants: tuple[str, ...] = ("llvm_ad_rgb", "scalar_rgb")) -> tuple[Any, str]:
    """Import Mitsuba and set the first of ``variants`` that works; ``(module, variant)``.

    Sets ``DRJIT_LIBLLVM_PATH`` to :data:`LLVM_DEFAULT` when unset and that file exists.
    Raises ``ImportError`` when Mitsuba is missing or no variant loads.
    """
    if os.path.exists(LLVM_DEFAULT):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM_DEFAULT)
    mi = require_extra("mitsuba")
    errors = []
    for variant in variants:
        try:
            mi.set_variant(variant)
            mi.load_dict({"type": "diffuse"})  # llvm variants fail here without libLLVM
        except Exception as error:  # Dr.Jit raises plain exceptions
            errors.append(f"{variant}: {error}")
            continue
        return mi, variant
    raise ImportError("no Mitsuba variant loads: " + "; ".join(errors))


def envmap_texels(env: EnvironmentMap) -> np.ndarray:
    """``env``'s radiance at Mitsuba's texel nodes, ``(H, W, 3)`` float32, scale applied."""
    height, width = env.image.shape[:2]
    theta = np.pi * np.arange(height) / (height - 1)
    phi = 2 * np.pi * (np.arange(width) + 0.5) / width
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d_map = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
    values = env.incident_radiance(np.zeros(3), d_map @ env.rotation.T)
    return np.ascontiguousarray(values, dtype=np.float32)


def envmap_emitter(mi: Any, env: EnvironmentMap) -> dict[str, Any]:
    """A Mitsuba ``envmap`` emitter dict equal to ``env`` (see the module's conventions)."""
    to_world = np.eye(4)
    to_world[:3, :3] = env.rotation @ MAP_TO_MITSUBA.T
    return {
        "type": "envmap",
        "bitmap": mi.Bitmap(envmap_texels(env)),
        "to_world": mi.ScalarTransform4f(to_world.tolist()),
    }


def sphere_scene(
    mi: Any, bsdf: dict[str, Any], env: EnvironmentMap | dict[str, Any], resolution: int = 256
):
    """A loaded Mitsuba scene: the unit sphere with ``bsdf`` under ``env``, brdfkit's camera
    (``env`` a map, or an emitter dict of Mitsuba's own, e.g. an ``envmap`` reading a file)."""
    return mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "direct", "hide_emitters": True},
            "sensor": {
                "type": "orthographic",
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=[10, 0, 0], target=[0, 0, 0], up=[0, 0, 1]
                ),
                "film": {
                    "type": "hdrfilm",
                    "width": resolution,
                    "height": resolution,
                    "pixel_format": "rgb",
                    "rfilter": {"type": "box"},
                },
                "sampler": {"type": "independent"},
            },
            "sphere": {"type": "sphere", "bsdf": bsdf},
            "light": env if isinstance(env, dict) else envmap_emitter(mi, env),
        }
    )


def directional_emitter(light: DirectionalLight) -> dict[str, Any]:
    """A Mitsuba ``directional`` emitter dict equal to ``light`` (its ``direction`` is the
    light's travel, minus brdfkit's direction towards the light)."""
    return {
        "type": "directional",
        "direction": (-np.asarray(light.direction, dtype=float)).tolist(),
        "irradiance": {
            "type": "rgb",
            "value": [float(v) for v in np.broadcast_to(light.irradiance, (3,))],
        },
    }


def mesh_scene(
    mi: Any,
    mesh_file: str,
    bsdf: dict[str, Any],
    emitters: dict[str, dict[str, Any]],
    look_at: tuple[Any, Any, Any],
    fov: float,
    size: tuple[int, int],
):
    """A loaded Mitsuba scene: the mesh file (PLY/OBJ) with ``bsdf`` under ``emitters``, seen by
    a ``perspective`` sensor with ``to_world=look_at(*look_at)``, horizontal ``fov`` degrees and
    ``size`` ``(height, width)``: what :func:`brdfkit.render.mesh.render_mesh` sees with
    :func:`brdfkit.render.mitsuba_frame.look_at_camera` (box filter: supersample it)."""
    origin, target, up = ([float(x) for x in v] for v in look_at)
    kind = "ply" if str(mesh_file).endswith(".ply") else "obj"
    return mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "direct", "hide_emitters": True},
            "sensor": {
                "type": "perspective",
                "fov": fov,
                "fov_axis": "x",
                "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=target, up=up),
                "film": {
                    "type": "hdrfilm",
                    "width": size[1],
                    "height": size[0],
                    "pixel_format": "rgb",
                    "rfilter": {"type": "box"},
                },
                "sampler": {"type": "independent"},
            },
            "mesh": {"type": kind, "filename": str(mesh_file), "bsdf": bsdf},
            **emitters,
        }
    )


def render(mi: Any, scene: Any, spp: int, seed: int = 0) -> np.ndarray:
    """Mitsuba's linear RGB image of ``scene``, ``(H, W, 3)`` float64."""
    return np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)


def relative_rmse(image: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> float:
    r""":math:`\sqrt{\overline{(x - r)^2}} / \sqrt{\overline{r^2}}` over ``mask`` and channels."""
    diff, ref = image[mask] - reference[mask], reference[mask]
    return float(np.sqrt(np.mean(diff * diff) / np.mean(ref * ref)))


__all__ = [
    "Scene",
    "benchmark_scenes",
    "directional_emitter",
    "envmap_emitter",
    "envmap_texels",
    "load_mitsuba",
    "mesh_scene",
    "relative_rmse",
    "render",
    "sphere_scene",
]
