"""Photometric stereo out of core, from a DiLiGenT folder to Zarr stores: the images staged,
solved tile by tile and integrated tile by tile (:mod:`brdfkit.distributed.tiled`), and the
angular error against the ground truth where the folder holds one.

The in-memory path (:func:`brdfkit.vision.reconstruction.reconstruct`) holds the float32 stack,
its float64 observations and the solver's copies: about 16 bytes per stack value.
:func:`exceeds_memory` says when that would pass :data:`MEMORY_SHARE` of the memory available,
the case for :func:`reconstruct_tiled`.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.distributed import tiled
from brdfkit.errors import require_extra

MEMORY_SHARE = 0.25
"""The in-memory path is taken while ~16 bytes per stack value fit in this share of the
available memory."""

BYTES_PER_VALUE = 16
"""Peak bytes of the in-memory path per stack value (float32 stack, float64 observations and
the solver's copies)."""

STORES = ("normals.zarr", "albedo.zarr", "depth.zarr")
"""The Zarr stores :func:`reconstruct_tiled` writes in its work folder."""


@dataclass(frozen=True)
class TiledReconstruction:
    """Output of :func:`reconstruct_tiled`.

    Attributes
    ----------
    stack : the staged data set (its lights, mask and name).
    method : the per-pixel method of :data:`brdfkit.distributed.tiled.PER_PIXEL`.
    tile : the tile side in pixels.
    stores : the Zarr stores by name (:data:`STORES`): normals ``(H, W, 3)``, albedo
        ``(H, W, C)`` (float32) and depth ``(H, W)``.
    normals, albedo : the stores' normals and albedo, read into memory.
    error_map : ``(H, W)`` angular error in degrees against ``Normal_gt.mat`` (NaN off the
        mask), or ``None`` without ground truth.
    """

    stack: tiled.Stack
    method: str
    tile: int
    stores: dict[str, Path]
    normals: np.ndarray
    albedo: np.ndarray
    error_map: np.ndarray | None

    def measures(self) -> dict[str, Any]:
        """The run and its measures as JSON-ready numbers (as ``brdfkit ps --chunks`` prints
        them)."""
        summary: dict[str, Any] = {
            "dataset": self.stack.name,
            "method": self.method,
            "integration": "least_squares (tiled)",
            "lights": len(self.stack.light_directions),
            "pixels": int(self.stack.mask.sum()),
            "out_of_core": {"tile": self.tile, "stack_bytes": self.stack.nbytes},
        }
        if self.error_map is not None:
            values = self.error_map[self.stack.mask]
            summary["angular_error_deg"] = {
                "mean": float(values.mean()),
                "median": float(np.median(values)),
            }
        return summary


def stack_values(folder: str | os.PathLike) -> int | None:
    """N × H × W × C of a DiLiGenT folder (from its listing and first image), or ``None`` when it
    is not one (the loaders then report what is wrong)."""
    from brdfkit.vision import datasets

    if not (Path(folder) / "filenames.txt").is_file():
        return None
    try:
        names = datasets.image_names(folder)
        first = datasets.read_image(Path(folder) / names[0])
    except (OSError, ValueError, IndexError):
        return None
    return len(names) * first.size


def exceeds_memory(folder: str | os.PathLike) -> bool:
    """Whether photometric stereo in memory on the DiLiGenT ``folder`` would need more than
    :data:`MEMORY_SHARE` of the available memory (``False`` when either is unknown)."""
    from brdfkit._checks import available_memory

    values, available = stack_values(folder), available_memory()
    return bool(values and available and BYTES_PER_VALUE * values > MEMORY_SHARE * available)


def reconstruct_tiled(
    folder: str | os.PathLike,
    work: str | os.PathLike,
    *,
    method: str = "least_squares",
    tile: int = tiled.DEFAULT_TILE,
    progress: Callable[[str], None] | None = None,
) -> TiledReconstruction:
    """Normals, albedo and depth of the DiLiGenT ``folder`` tile by tile, as Zarr stores in
    ``work``, on the current Dask client (or Dask's default scheduler).

    The images are staged to ``work/stack.zarr`` (:func:`~brdfkit.distributed.tiled.stage`),
    ``method`` runs on each tile (:func:`~brdfkit.distributed.tiled.solve`) and the depth is
    integrated on tiles overlapping by ``min(OVERLAP, tile // 4)`` pixels
    (:func:`~brdfkit.distributed.tiled.integrate`).

    Parameters
    ----------
    folder : a DiLiGenT object folder.
    work : an existing folder for the stack and the stores (on the file system of their final
        place, so that they can be moved there by renaming).
    method : a method of :data:`~brdfkit.distributed.tiled.PER_PIXEL`.
    tile : the tile side in pixels (at least 16).
    progress : ``progress(stage)`` as each stage begins.

    Raises
    ------
    brdfkit.errors.FormatError
        As :func:`~brdfkit.distributed.tiled.stage` reads the folder, or a bad
        ``Normal_gt.mat``.
    brdfkit.errors.ParameterError
        A method that couples pixels, or a tile below 16.
    """
    zarr = require_extra("zarr")

    from brdfkit.vision.datasets import read_normal_gt
    from brdfkit.vision.metrics import angular_error_map

    report = progress if progress is not None else (lambda stage: None)
    work = Path(work)
    stores = {name: work / name for name in STORES}
    report("staging the images to Zarr")
    stack = tiled.stage(folder, work / "stack.zarr", tile)
    report(f"{method} tile by tile ({tile}²)")
    tiled.solve(stack, method, stores["normals.zarr"], stores["albedo.zarr"])
    report("integrating tile by tile")
    overlap = min(tiled.OVERLAP, tile // 4)
    tiled.integrate(
        stores["normals.zarr"], stack.mask, stores["depth.zarr"], tile=tile, overlap=overlap
    )
    normals = np.asarray(zarr.open_array(str(stores["normals.zarr"]), mode="r")[:])
    albedo = np.asarray(zarr.open_array(str(stores["albedo.zarr"]), mode="r")[:])
    error_map = None
    if stack.normals_file is not None:
        truth = read_normal_gt(stack.normals_file, stack.mask)
        error_map = angular_error_map(normals.astype(np.float64), truth, stack.mask)
    return TiledReconstruction(stack, method, tile, stores, normals, albedo, error_map)
