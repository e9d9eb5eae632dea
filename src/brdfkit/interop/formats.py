"""One entry point for every export format: :func:`export` writes a BRDF to a file of the
format asked for, atomically, and says what the conversion approximated.

====================  =============  ==========================================================
format                suffixes       what is written
====================  =============  ==========================================================
``mitsuba``           ``.xml``       a Mitsuba 3 ``<bsdf>`` (:mod:`~brdfkit.interop.mitsuba_export`)
``rgl``               ``.bsdf``      an RGL tensor file (:func:`brdfkit.measured.write_rgl`)
``gltf``              ``.gltf``,     a glTF 2.0 material on a UV sphere
                      ``.glb``       (:mod:`~brdfkit.interop.gltf`)
``mtlx``              ``.mtlx``      a MaterialX 1.39 OpenPBR document
                                     (:mod:`~brdfkit.interop.materialx`)
``usd``               ``.usda``,     a UsdPreviewSurface material on a sphere
                      ``.usd``,      (:mod:`~brdfkit.interop.usd`)
                      ``.usdc``
====================  =============  ==========================================================

Examples
--------
>>> import tempfile
>>> from pathlib import Path
>>> from brdfkit.brdf import Lambertian
>>> with tempfile.TemporaryDirectory() as folder:
...     done = export(Lambertian(0.5), "mitsuba", Path(folder) / "white.xml")
...     print(done.path.name, done.approximations)
white.xml []
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from brdfkit.brdf import BRDF
from brdfkit.errors import ParameterError

FORMATS: dict[str, tuple[str, ...]] = {
    "mitsuba": (".xml",),
    "rgl": (".bsdf",),
    "gltf": (".gltf", ".glb"),
    "mtlx": (".mtlx",),
    "usd": (".usda", ".usd", ".usdc"),
}
"""Each export format and the file suffixes it writes (the first is the default)."""


@dataclass(frozen=True)
class Exported:
    """What :func:`export` wrote: the file, and the conversion's approximations in words
    (empty when the file evaluates as the model does)."""

    path: Path
    approximations: list[str] = field(default_factory=list)


def check_format(format: str, path: str | os.PathLike | None = None) -> str:
    """``format`` lower-cased, after checking it is known and that ``path`` ends in one of its
    suffixes.

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming the format or the path and what was expected.
    """
    name = str(format).lower()
    if name not in FORMATS:
        raise ParameterError(f"format must be one of {', '.join(FORMATS)}; got {format!r}")
    if path is not None and Path(path).suffix.lower() not in FORMATS[name]:
        raise ParameterError(
            f"a {name} file must end in {', '.join(FORMATS[name])}; got {Path(path).name!r}"
        )
    return name


def export(
    brdf: BRDF, format: str, path: str | os.PathLike, *, approximate: bool = False
) -> Exported:
    """Write ``brdf`` as a ``format`` file at ``path`` (atomically).

    Parameters
    ----------
    brdf : the model (or measured BRDF: ``rgl`` takes any).
    format : one of :data:`FORMATS`.
    path : the file; its suffix must be one of the format's.
    approximate : for ``mitsuba``, export the nearest plugin where an option has no exact
        counterpart instead of refusing (the glTF, MaterialX and USD materials are always
        approximations, listed in :attr:`Exported.approximations`).

    Raises
    ------
    brdfkit.errors.ParameterError
        For an unknown format, a wrong suffix, or a model the format cannot express (named).
    """
    name = check_format(format, path)
    path = Path(path)
    if name == "mitsuba":
        from brdfkit.interop.mitsuba_export import mitsuba_approximations, write_mitsuba_xml

        write_mitsuba_xml(brdf, path, approximate=approximate)
        notes = mitsuba_approximations(brdf) if approximate else []
        return Exported(path, notes)
    if name == "rgl":
        from brdfkit.measured import write_rgl

        return Exported(write_rgl(brdf, path, description=_description(brdf)))
    from brdfkit.interop.pbr import pbr_material

    notes = list(pbr_material(brdf).approximations)
    if name == "gltf":
        from brdfkit.interop.gltf import write_gltf

        return Exported(write_gltf(brdf, path), notes)
    if name == "mtlx":
        from brdfkit.interop.materialx import write_materialx

        return Exported(write_materialx(brdf, path), notes)
    from brdfkit.interop.usd import write_usd

    return Exported(write_usd(brdf, path), notes)


def _description(brdf: BRDF) -> str:
    """A model's spec string, or its type for data without one."""
    try:
        return brdf.to_spec()
    except ValueError:
        return repr(brdf)


__all__ = ["FORMATS", "Exported", "check_format", "export"]
