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

from __future__ import annotations

import importlib
from typing import Any

_HOMES = {
    "FORMATS": "formats",
    "Exported": "formats",
    "check_format": "formats",
    "export": "formats",
    "mitsuba_approximations": "mitsuba_export",
    "to_mitsuba_dict": "mitsuba_export",
    "to_mitsuba_xml": "mitsuba_export",
    "write_mitsuba_xml": "mitsuba_export",
}
"""Each name of the package and its module, imported when the name is first asked for: a
command that only loads a model (:mod:`~brdfkit.interop.load`) does not pay for the writers
(the XML writer's ``xml.sax`` imports ``urllib.request`` and ``http.client``)."""

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


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
