r"""brdfkit models as USD stages: a ``UsdPreviewSurface`` material bound to a unit sphere, with
``usd-core``.

The parameters are :func:`brdfkit.interop.pbr.pbr_material`'s (its docstring states the
approximations). UsdPreviewSurface's ``roughness`` is the perceptual r (α = r², as glTF). A
metal uses the metallic workflow (``metallic`` 1, ``diffuseColor`` = F0); a dielectric the
specular workflow (``useSpecularWorkflow`` 1) with ``specularColor`` =
:func:`~brdfkit.interop.pbr.dielectric_f0` and ``ior``; ``clearcoat`` and
``clearcoatRoughness`` carry a coat. UsdPreviewSurface has no sheen (dropped) and no
transmission weight: a transmissive material is written with ``opacity`` 1 − transmission
(its refraction by ``ior``).

References
----------
.. [1] Pixar, "UsdPreviewSurface Specification" 2.5, https://openusd.org.

Examples
--------
>>> from pxr import UsdShade
>>> from brdfkit.brdf import RoughConductor
>>> stage = usd_stage(RoughConductor(alpha=0.25, material="Au"))
>>> shader = stage.GetPrimAtPath("/brdfkit/Material/PreviewSurface")
>>> inputs = UsdShade.Shader(shader)
>>> round(inputs.GetInput("roughness").Get(), 6), inputs.GetInput("metallic").Get()
(0.5, 1.0)
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf import BRDF
from brdfkit.errors import require_extra
from brdfkit.interop.pbr import dielectric_f0, pbr_material
from brdfkit.io import atomic_write


def usd_stage(brdf: BRDF, *, name: str = "brdfkit") -> Any:
    """An in-memory stage: ``/<name>/Sphere`` (radius 1) bound to ``/<name>/Material``, whose
    ``PreviewSurface`` shader holds ``brdf``'s parameters."""
    require_extra("pxr")
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

    material = pbr_material(brdf)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    root = UsdGeom.Xform.Define(stage, f"/{name}")
    stage.SetDefaultPrim(root.GetPrim())
    sphere = UsdGeom.Sphere.Define(stage, f"/{name}/Sphere")
    sphere.CreateRadiusAttr(1.0)
    look = UsdShade.Material.Define(stage, f"/{name}/Material")
    shader = UsdShade.Shader.Define(stage, f"/{name}/Material/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for key, (kind, value) in _inputs(material).items():
        sdf_type = {"color": Sdf.ValueTypeNames.Color3f, "float": Sdf.ValueTypeNames.Float,
                    "int": Sdf.ValueTypeNames.Int}[kind]  # fmt: skip
        shader.CreateInput(key, sdf_type).Set(Gf.Vec3f(*value) if kind == "color" else value)
    look.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(sphere.GetPrim()).Bind(look)
    return stage


def _inputs(material: Any) -> dict[str, tuple[str, Any]]:
    """UsdPreviewSurface inputs as ``name: (kind, value)``."""
    colour = [float(c) for c in material.base_color]
    inputs = {
        "diffuseColor": ("color", colour),
        "roughness": ("float", float(material.roughness)),
        "clearcoat": ("float", float(material.clearcoat)),
        "clearcoatRoughness": ("float", float(material.clearcoat_roughness)),
        "opacity": ("float", float(1 - material.transmission)),
        "ior": ("float", float(material.ior)),
    }
    if material.metallic > 0:
        inputs["metallic"] = ("float", float(material.metallic))
        return inputs
    specular = [float(c) for c in np.broadcast_to(dielectric_f0(material), (3,))]
    inputs["useSpecularWorkflow"] = ("int", 1)
    inputs["specularColor"] = ("color", specular)
    return inputs


def write_usd(brdf: BRDF, path: str | os.PathLike, *, name: str = "brdfkit") -> Path:
    """Write :func:`usd_stage` atomically (``.usda`` text, ``.usdc`` or ``.usd`` crate, by the
    suffix); returns the path."""
    stage = usd_stage(brdf, name=name)
    return atomic_write(path, lambda tmp: _export(stage, tmp))


def _export(stage: Any, path: Path) -> None:
    if not stage.GetRootLayer().Export(str(path)):
        raise OSError(f"USD could not write {path}")


__all__ = ["usd_stage", "write_usd"]
