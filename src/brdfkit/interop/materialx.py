r"""brdfkit models as MaterialX 1.39 documents: an OpenPBR Surface (``open_pbr_surface``) and its
``surfacematerial``, with the ``materialx`` package.

The parameters are :func:`brdfkit.interop.pbr.pbr_material`'s (its docstring states the
approximations), in OpenPBR's names: ``base_color``, ``base_metalness``,
``specular_roughness`` (α = r², as glTF), ``specular_ior`` — chosen so that OpenPBR's
dielectric :math:`F_0` equals the material's largest channel of
:func:`~brdfkit.interop.pbr.dielectric_f0`, its colour the ``specular_color`` —, ``coat_weight``
and ``coat_roughness`` (coat index 1.5), ``fuzz_*`` for sheen, and ``transmission_weight``
with ``geometry_thin_walled``. Each document is validated against the standard data libraries
before it is written.

References
----------
.. [1] Academy Software Foundation, "MaterialX Specification" 1.39, 2024,
       https://materialx.org.
.. [2] A. Andersson, P. Kutz et al., "OpenPBR Surface Specification" 1.1, 2024.

Examples
--------
>>> from brdfkit.brdf import Lambertian, GGXConductor
>>> doc = materialx_document(Lambertian([0.5, 0.2, 0.1]) + 0.5 * GGXConductor(alpha=0.1))
>>> shader = doc.getNode("brdfkit_surface")
>>> shader.getCategory(), round(shader.getInputValue("specular_roughness"), 4)
('open_pbr_surface', 0.3162)
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf import BRDF
from brdfkit.errors import ParameterError, require_extra
from brdfkit.interop.pbr import dielectric_f0, ior_from_f0, pbr_material
from brdfkit.io import atomic_write


def standard_libraries() -> Any:
    """A MaterialX document holding the standard data libraries (``stdlib``, ``pbrlib``,
    ``bxdf`` with OpenPBR, …), from the package's default folders."""
    mx = require_extra("MaterialX")

    stdlib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), stdlib)
    return stdlib


def validation_problems(document: Any, stdlib: Any | None = None) -> str:
    """MaterialX's ``validate()`` message for ``document`` with the standard libraries imported
    (into a copy); empty when it is valid."""
    mx = require_extra("MaterialX")

    check = mx.createDocument()
    check.copyContentFrom(document)
    check.importLibrary(standard_libraries() if stdlib is None else stdlib)
    valid, message = check.validate()
    return "" if valid else message


def materialx_document(brdf: BRDF, *, name: str = "brdfkit") -> Any:
    """A MaterialX document: an ``open_pbr_surface`` named ``<name>_surface`` and the
    ``surfacematerial`` ``<name>`` that uses it."""
    mx = require_extra("MaterialX")

    material = pbr_material(brdf)
    f0 = dielectric_f0(material)
    peak = float(f0.max())
    colour = f0 / peak if peak > 0 else np.ones(3)
    inputs: dict[str, Any] = {
        "base_color": mx.Color3(*map(float, material.base_color)),
        "base_metalness": float(material.metallic),
        "specular_weight": 1.0 if peak > 0 else 0.0,
        "specular_color": mx.Color3(*map(float, colour)),
        "specular_roughness": float(material.roughness),
        "specular_ior": float(ior_from_f0(peak)) if peak > 0 else float(material.ior),
        "coat_weight": float(material.clearcoat),
        "coat_roughness": float(material.clearcoat_roughness),
        "fuzz_weight": 1.0 if np.any(material.sheen_color > 0) else 0.0,
        "fuzz_color": mx.Color3(*map(float, material.sheen_color)),
        "fuzz_roughness": float(material.sheen_roughness),
        "transmission_weight": float(material.transmission),
        "geometry_thin_walled": bool(material.transmission > 0),
    }
    document = mx.createDocument()
    shader = document.addNode("open_pbr_surface", f"{name}_surface", "surfaceshader")
    for key, value in inputs.items():
        shader.setInputValue(key, value)
    document.addMaterialNode(name, shader)
    return document


def write_materialx(brdf: BRDF, path: str | os.PathLike, *, name: str = "brdfkit") -> Path:
    """Write :func:`materialx_document` as a ``.mtlx`` file atomically, after checking it with
    ``validate()`` against the standard libraries; returns the path.

    Raises
    ------
    brdfkit.errors.ParameterError
        As :func:`~brdfkit.interop.pbr.pbr_material`, or if the document does not validate
        (its message quoted).
    """
    mx = require_extra("MaterialX")

    document = materialx_document(brdf, name=name)
    problems = validation_problems(document)
    if problems:
        raise ParameterError(
            f"the MaterialX document of {type(brdf).__name__} is invalid: {problems}"
        )
    text = mx.writeToXmlString(document)
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


__all__ = ["materialx_document", "standard_libraries", "validation_problems", "write_materialx"]
