"""Named real-material presets: published fits to the MERL measurements as ordinary BRDFs.

``preset("alum-bronze", "ngan_ward")`` is a BRDF; so is the spec
``material(name='alum-bronze', fit='ngan_ward')``. :func:`fits` lists the fits,
:func:`materials` the materials of one, :func:`citation` its paper; :func:`catalogue` gives one
record per preset (what ``brdfkit materials`` prints). The conversions are documented in
:mod:`brdfkit.brdf.material`.
"""

from __future__ import annotations

from typing import Any

from brdfkit.brdf.material import (
    CONVERTERS,
    UNCONVERTED,
    Material,
    citation,
    fits,
    materials,
    preset,
    tables,
)


def catalogue(fit: str | None = None, model: str | None = None) -> list[dict[str, Any]]:
    """One record per preset: ``{"name", "fit", "model", "spec", "citation"}``.

    ``fit`` keeps one fit; ``model`` keeps the fits whose ``bbm`` model name or fit name
    contains it (case-insensitive: ``"ward"`` keeps ``ngan_ward`` and ``ngan_wardduer``).
    """
    chosen = fits() if fit is None else (fit,)
    records = []
    for key in chosen:
        bbm_model = tables()["sources"][key]["model"] if key in fits() else ""
        if model is not None and model.lower() not in f"{key} {bbm_model}".lower():
            continue
        for name in materials(key):
            records.append(
                {
                    "name": name,
                    "fit": key,
                    "model": bbm_model,
                    "spec": Material(name, key).to_spec(),
                    "citation": citation(key),
                }
            )
    return records


# Material is documented at brdfkit.brdf.Material (imported here for catalogue()).
__all__ = [
    "CONVERTERS",
    "UNCONVERTED",
    "catalogue",
    "citation",
    "fits",
    "materials",
    "preset",
    "tables",
]
