"""Interoperability with the tools of the field.

:mod:`~brdfkit.interop.mitsuba`: Mitsuba 3 scenes that see exactly what brdfkit's sphere
renders see (the oracle of the rendering tests and the peer of the benchmarks).
:mod:`~brdfkit.interop.load`: :func:`brdfkit.load`, a BRDF from any source (BRDF Explorer too).
:mod:`~brdfkit.interop.mitsuba_export`: brdfkit models as Mitsuba 3 BSDFs (dict and XML).
:mod:`~brdfkit.interop.pbr`: the metallic-roughness conversion that
:mod:`~brdfkit.interop.gltf` (glTF 2.0), :mod:`~brdfkit.interop.materialx` (OpenPBR) and
:mod:`~brdfkit.interop.usd` (UsdPreviewSurface) write. :mod:`~brdfkit.interop.formats`: one
entry point for every format, RGL tables (:func:`brdfkit.measured.write_rgl`) included.
"""

from brdfkit.interop.formats import FORMATS, Exported, check_format, export
from brdfkit.interop.mitsuba_export import (
    mitsuba_approximations,
    to_mitsuba_dict,
    to_mitsuba_xml,
    write_mitsuba_xml,
)

__all__ = [
    "FORMATS",
    "Exported",
    "check_format",
    "export",
    "mitsuba_approximations",
    "to_mitsuba_dict",
    "to_mitsuba_xml",
    "write_mitsuba_xml",
]
