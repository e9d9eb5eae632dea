r"""brdfkit models as glTF 2.0 materials on a UV sphere (``.gltf`` or ``.glb``), with pygltflib.

The material is :func:`brdfkit.interop.pbr.pbr_material`'s metallic-roughness conversion (its
docstring states the approximations): the core ``pbrMetallicRoughness`` (``baseColorFactor``,
``metallicFactor``, ``roughnessFactor``) plus, where they apply, ``KHR_materials_ior``,
``KHR_materials_specular`` (``specularFactor``, ``specularColorFactor``),
``KHR_materials_clearcoat``, ``KHR_materials_sheen`` and ``KHR_materials_transmission``.
The mesh is a unit UV sphere (positions, normals, texture coordinates), so that the file opens
in any viewer as a material ball. Colours are linear, as glTF's factors are.

References
----------
.. [1] The Khronos Group, "glTF 2.0 Specification", 2021, §3.9 (materials), Appendix B;
       the KHR_materials_* extension specifications.
.. [2] pygltflib, https://gitlab.com/dodgyville/pygltflib.

Examples
--------
>>> import tempfile
>>> from pathlib import Path
>>> from brdfkit.brdf import Principled
>>> with tempfile.TemporaryDirectory() as folder:
...     path = write_gltf(Principled(base_color=[0.8, 0.2, 0.1], clearcoat=1.0),
...                       Path(folder) / "ball.glb")
...     document = gltf_document(Principled(base_color=[0.8, 0.2, 0.1], clearcoat=1.0))
>>> document.extensionsUsed
['KHR_materials_clearcoat']
>>> document.materials[0].pbrMetallicRoughness.baseColorFactor
[0.8, 0.2, 0.1, 1.0]
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf import BRDF
from brdfkit.errors import require_extra
from brdfkit.interop.pbr import GLTF_IOR, PBRMaterial, pbr_material
from brdfkit.io import atomic_write


def uv_sphere(rings: int = 32, segments: int = 64) -> dict[str, np.ndarray]:
    """A unit UV sphere: ``positions`` and ``normals`` (n, 3), ``uvs`` (n, 2) float32 and
    ``indices`` (m, 3) uint32, counter-clockwise seen from outside, +y up (glTF's)."""
    theta = np.linspace(0.0, math.pi, rings + 1)
    phi = np.linspace(0.0, 2 * math.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    positions = np.stack([np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], -1)
    uvs = np.stack([p / (2 * math.pi), t / math.pi], -1)
    row = segments + 1
    i, j = np.meshgrid(np.arange(rings), np.arange(segments), indexing="ij")
    a, b = i * row + j, (i + 1) * row + j
    lower = np.stack([a, b, b + 1], -1)[i < rings - 1]  # the last ring's meets at the pole
    upper = np.stack([a, b + 1, a + 1], -1)[i > 0]  # the first ring's meets at the pole
    positions = positions.reshape(-1, 3).astype(np.float32)
    return {
        "positions": positions,
        "normals": positions.copy(),
        "uvs": uvs.reshape(-1, 2).astype(np.float32),
        "indices": np.concatenate([lower, upper]).astype(np.uint32),
    }


def gltf_material(material: PBRMaterial) -> tuple[dict[str, Any], list[str]]:
    """The glTF material object (a dict) of a metallic-roughness material and the extensions
    it uses."""
    core = {
        "baseColorFactor": [*map(float, material.base_color), 1.0],
        "metallicFactor": float(material.metallic),
        "roughnessFactor": float(material.roughness),
    }
    extensions: dict[str, dict[str, Any]] = {}
    if not math.isclose(material.ior, GLTF_IOR, rel_tol=1e-9):
        extensions["KHR_materials_ior"] = {"ior": float(material.ior)}
    if material.specular_weight != 1 or np.any(material.specular_color != 1):
        extensions["KHR_materials_specular"] = {
            "specularFactor": float(material.specular_weight),
            "specularColorFactor": [float(c) for c in material.specular_color],
        }
    if material.clearcoat > 0:
        extensions["KHR_materials_clearcoat"] = {
            "clearcoatFactor": float(material.clearcoat),
            "clearcoatRoughnessFactor": float(material.clearcoat_roughness),
        }
    if np.any(material.sheen_color > 0):
        extensions["KHR_materials_sheen"] = {
            "sheenColorFactor": [float(c) for c in material.sheen_color],
            "sheenRoughnessFactor": float(material.sheen_roughness),
        }
    if material.transmission > 0:
        extensions["KHR_materials_transmission"] = {
            "transmissionFactor": float(material.transmission)
        }
    spec = {"name": "brdfkit", "pbrMetallicRoughness": core}
    if extensions:
        spec["extensions"] = extensions
    return spec, sorted(extensions)


def gltf_document(brdf: BRDF, *, name: str = "brdfkit") -> Any:
    """A ``pygltflib.GLTF2`` document: ``brdf``'s material on a UV sphere, its buffer held
    as binary (``save_binary``) — :func:`write_gltf` embeds it for ``.gltf``."""
    gl = require_extra("pygltflib")

    spec, used = gltf_material(pbr_material(brdf))
    spec["name"] = name
    sphere = uv_sphere()
    blobs = [sphere["positions"], sphere["normals"], sphere["uvs"], sphere["indices"].reshape(-1)]
    views, offset = [], 0
    for blob, target in zip(blobs, [gl.ARRAY_BUFFER] * 3 + [gl.ELEMENT_ARRAY_BUFFER], strict=True):
        views.append(gl.BufferView(buffer=0, byteOffset=offset, byteLength=blob.nbytes,
                                   target=target))  # fmt: skip
        offset += blob.nbytes
    positions = sphere["positions"]
    accessors = [
        gl.Accessor(bufferView=0, componentType=gl.FLOAT, count=len(positions), type=gl.VEC3,
                    min=positions.min(0).tolist(), max=positions.max(0).tolist()),
        gl.Accessor(bufferView=1, componentType=gl.FLOAT, count=len(positions), type=gl.VEC3),
        gl.Accessor(bufferView=2, componentType=gl.FLOAT, count=len(positions), type=gl.VEC2),
        gl.Accessor(bufferView=3, componentType=gl.UNSIGNED_INT,
                    count=sphere["indices"].size, type=gl.SCALAR),
    ]  # fmt: skip
    primitive = gl.Primitive(
        attributes=gl.Attributes(POSITION=0, NORMAL=1, TEXCOORD_0=2), indices=3, material=0
    )
    document = gl.GLTF2(
        asset=gl.Asset(generator="brdfkit", version="2.0"),
        scene=0,
        scenes=[gl.Scene(nodes=[0])],
        nodes=[gl.Node(mesh=0, name=name)],
        meshes=[gl.Mesh(primitives=[primitive], name="sphere")],
        materials=[gl.Material(**{k: v for k, v in spec.items() if k != "pbrMetallicRoughness"},
                               pbrMetallicRoughness=gl.PbrMetallicRoughness(
                                   **spec["pbrMetallicRoughness"]))],
        accessors=accessors,
        bufferViews=views,
        buffers=[gl.Buffer(byteLength=offset)],
        extensionsUsed=used,
    )  # fmt: skip
    document.set_binary_blob(b"".join(np.ascontiguousarray(b).tobytes() for b in blobs))
    return document


def write_gltf(brdf: BRDF, path: str | os.PathLike, *, name: str = "brdfkit") -> Path:
    """Write :func:`gltf_document` atomically: binary ``.glb``, or ``.gltf`` JSON with the
    buffer embedded as a data URI; returns the path."""
    gl = require_extra("pygltflib")

    document = gltf_document(brdf, name=name)
    if Path(path).suffix.lower() == ".glb":
        return atomic_write(path, lambda tmp: document.save_binary(str(tmp)))
    document.convert_buffers(gl.BufferFormat.DATAURI)
    return atomic_write(path, lambda tmp: document.save_json(str(tmp)))


__all__ = ["gltf_document", "gltf_material", "uv_sphere", "write_gltf"]
