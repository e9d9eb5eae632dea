"""``brdfkit ps`` out of core: a DiLiGenT folder solved tile by tile on Dask
(:func:`brdfkit.distributed.tiled_reconstruction.reconstruct_tiled`), when ``--chunks`` asks for
it or the stack would not fit in memory."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import typer

from brdfkit.cli._app import console, fail, progress, shown
from brdfkit.cli._output import OutputFolder

DEFAULT_METHOD = "sparse_regression"
"""The method out of core unless ``--method`` names another: of the per-pixel methods
(:data:`brdfkit.distributed.tiled.PER_PIXEL`), the one with the lowest error on the renders of
``benchmarks/bench_ps_materials.py``."""

OUTPUTS = ("normals.zarr", "albedo.zarr", "depth.zarr", "normals.png", "albedo.png",
           "lights.txt", "angular_error.png")  # fmt: skip


def wanted(dataset: Path, chunks: int | None, step: int) -> bool:
    """Whether to go out of core: ``--chunks`` given, or a stack too large for memory (with
    Dask installed)."""
    import importlib.util

    if chunks is not None:
        return True
    if importlib.util.find_spec("distributed") is None:  # the in-memory path says what fits
        return False
    from brdfkit.distributed.tiled_reconstruction import exceeds_memory

    return step == 1 and exceeds_memory(dataset)


def _check(method: str, integration: str | None, options: dict[str, Any]) -> None:
    """Exit naming the first option that the tiled path cannot honour."""
    from brdfkit.distributed import tiled

    for name, value in options.items():
        if value:
            fail(f"{name} is not available out of core (--chunks or a stack beyond memory)")
    if method not in tiled.PER_PIXEL:
        fail(f"--method {method!r} couples pixels; out of core use {', '.join(tiled.PER_PIXEL)}")
    if integration not in (None, "least_squares"):
        fail(f"--integration {integration!r}: out of core the depth is tiled least squares")


def run(
    dataset: Path, method: str | None, integration: str | None, chunks: int | None,
    options: dict[str, Any], output: Path, as_json: bool,
) -> None:  # fmt: skip
    """Solve and integrate tile by tile, write the outputs, print the measures."""
    from brdfkit.distributed import cluster, tiled
    from brdfkit.distributed.tiled_reconstruction import STORES, reconstruct_tiled

    cluster.require_dask()
    method = method or DEFAULT_METHOD
    _check(method, integration, options)
    tile = chunks or tiled.DEFAULT_TILE
    folder = OutputFolder(output, OUTPUTS, inputs=(dataset,))
    output.mkdir(parents=True, exist_ok=True)
    with (
        tempfile.TemporaryDirectory(prefix=".brdfkit-stack-", dir=output) as scratch,
        cluster.client(),  # Dask's default scheduler while it is open
        progress() as bar,
    ):
        task = bar.add_task("", total=None)
        surface = reconstruct_tiled(
            dataset, scratch, method=method, tile=tile,
            progress=lambda stage: bar.update(task, description=stage),
        )  # fmt: skip
        for name in STORES:
            folder.write_folder(name, lambda p, name=name: os.replace(surface.stores[name], p))
    files = [*STORES, *_write_previews(folder, surface)]
    summary = surface.measures()
    summary["output"], summary["files"] = shown(output), files
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    errors = summary.get("angular_error_deg")
    console.print(f"{surface.stack.name}: {method} out of core, {tile}² tiles, "
                  f"{summary['pixels']} pixels"
                  + (f", mean angular error {errors['mean']:.2f}°" if errors else ""))  # fmt: skip
    console.print(f"wrote {shown(output)}/")


def _write_previews(folder: OutputFolder, surface: Any) -> list[str]:
    """Write normals.png, albedo.png, lights.txt and, with ground truth, angular_error.png;
    return their names."""
    import numpy as np

    from brdfkit.cli._previews import albedo_preview, error_preview
    from brdfkit.io import write_image
    from brdfkit.vision.datasets import write_normal_map

    mask, lights = surface.stack.mask, surface.stack.light_directions
    folder.write("normals.png", lambda p: write_normal_map(p, surface.normals))
    folder.write("albedo.png", lambda p: write_image(p, albedo_preview(surface.albedo, mask)))
    folder.write("lights.txt", lambda p: np.savetxt(p, lights, fmt="%.8f"))
    if surface.error_map is None:
        return ["normals.png", "albedo.png", "lights.txt"]
    shown_map = error_preview(surface.error_map)
    folder.write("angular_error.png", lambda p: write_image(p, shown_map, srgb=False))
    return ["normals.png", "albedo.png", "lights.txt", "angular_error.png"]
