"""``brdfkit ps`` out of core: a DiLiGenT folder staged to Zarr and solved tile by tile on Dask
(:mod:`brdfkit.distributed.tiled`), when ``--chunks`` asks for it or the stack would not fit."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import typer

from brdfkit.cli._app import console, fail, progress, shown
from brdfkit.cli._output import OutputFolder

MEMORY_SHARE = 0.25
"""The in-memory path is taken while ~16 bytes per stack value (float32 stack plus float64
observations and the solver's copies) fit in this share of the available memory."""

OUTPUTS = ("normals.zarr", "albedo.zarr", "depth.zarr", "normals.png", "albedo.png",
           "lights.txt", "angular_error.png")  # fmt: skip


def stack_values(dataset: Path) -> int | None:
    """N × H × W × C of a DiLiGenT folder (from its listing and first image), or ``None`` when it
    is not one (the in-memory loader then reports what is wrong)."""
    from brdfkit.vision import datasets

    listing = dataset / "filenames.txt"
    if not listing.is_file():
        return None
    try:
        names = [token for _, tokens in datasets._lines(listing) for token in tokens]
        first = datasets.read_image(dataset / names[0])
    except (OSError, ValueError, IndexError):
        return None
    return len(names) * first.size


def wanted(dataset: Path, chunks: int | None, step: int) -> bool:
    """Whether to go out of core: ``--chunks`` given, or a stack too large for memory (with
    Dask installed)."""
    from brdfkit._checks import available_memory

    if chunks is not None:
        return True
    import importlib.util

    if importlib.util.find_spec("distributed") is None:  # the in-memory path says what fits
        return False
    values, available = stack_values(dataset), available_memory()
    return bool(values and available and step == 1 and 16 * values > MEMORY_SHARE * available)


def run(
    dataset: Path, method: str, integration: str, chunks: int | None, options: dict[str, Any],
    output: Path, as_json: bool,
) -> None:  # fmt: skip
    """Stage, solve, integrate and write the outputs of the tiled path."""
    import numpy as np
    import zarr

    from brdfkit.distributed import cluster, tiled
    from brdfkit.io import write_image
    from brdfkit.vision import datasets
    from brdfkit.vision.metrics import angular_error_map

    cluster.require_dask()
    for name, value in options.items():
        if value:
            fail(f"{name} is not available out of core (--chunks or a stack beyond memory)")
    if method not in tiled.PER_PIXEL:
        fail(f"--method {method!r} couples pixels; out of core use {', '.join(tiled.PER_PIXEL)}")
    if integration != "least_squares":
        fail(f"--integration {integration!r}: out of core the depth is tiled least squares")
    tile = chunks or tiled.DEFAULT_TILE
    folder = OutputFolder(output, OUTPUTS, inputs=(dataset,))
    output.mkdir(parents=True, exist_ok=True)
    with (
        tempfile.TemporaryDirectory(prefix=".brdfkit-stack-", dir=output) as scratch,
        cluster.client(),  # Dask's default scheduler while it is open
        progress() as bar,
    ):
        work = Path(scratch)
        task = bar.add_task("staging the images to Zarr", total=None)
        stack = tiled.stage(dataset, work / "stack.zarr", tile)
        bar.update(task, description=f"{method} tile by tile ({tile}²)")
        tiled.solve(stack, method, work / "normals.zarr", work / "albedo.zarr")
        bar.update(task, description="integrating tile by tile")
        tiled.integrate(
            work / "normals.zarr", stack.mask, work / "depth.zarr", tile=tile,
            overlap=min(tiled.OVERLAP, tile // 4),
        )  # fmt: skip
        for name in ("normals.zarr", "albedo.zarr", "depth.zarr"):
            folder.write_folder(name, lambda p, name=name: os.replace(work / name, p))
    normals = np.asarray(zarr.open_array(str(output / "normals.zarr"), mode="r")[:])
    albedo = np.asarray(zarr.open_array(str(output / "albedo.zarr"), mode="r")[:])
    mask = stack.mask
    scale = np.percentile(albedo[mask], 99) or 1.0
    folder.write("normals.png", lambda p: datasets.write_normal_map(p, normals))
    folder.write("albedo.png", lambda p: write_image(p, (albedo / scale).clip(0, 1)))
    folder.write("lights.txt", lambda p: np.savetxt(p, stack.light_directions, fmt="%.8f"))
    summary: dict[str, Any] = {
        "dataset": stack.name, "method": method, "integration": "least_squares (tiled)",
        "lights": len(stack.light_directions), "pixels": int(mask.sum()),
        "out_of_core": {"tile": tile, "stack_bytes": stack.nbytes},
    }  # fmt: skip
    files = ["normals.zarr", "albedo.zarr", "depth.zarr", "normals.png", "albedo.png", "lights.txt"]
    if stack.normals_file is not None:
        truth = datasets._read_normal_gt(Path(stack.normals_file), mask)
        error_map = angular_error_map(normals.astype(np.float64), truth, mask)
        values = error_map[mask]
        summary["angular_error_deg"] = {"mean": float(values.mean()),
                                        "median": float(np.median(values))}  # fmt: skip
        shown_map = np.nan_to_num(error_map / 45.0, nan=0.0).clip(0, 1).astype(np.float32)
        folder.write("angular_error.png", lambda p: write_image(p, shown_map, srgb=False))
        files.append("angular_error.png")
    summary["output"], summary["files"] = shown(output), files
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    errors = summary.get("angular_error_deg")
    console.print(f"{stack.name}: {method} out of core, {tile}² tiles, {summary['pixels']} pixels"
                  + (f", mean angular error {errors['mean']:.2f}°" if errors else ""))  # fmt: skip
    console.print(f"wrote {shown(output)}/")
