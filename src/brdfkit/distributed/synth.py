"""Rendering photometric-stereo data sets as Dask tasks: shapes × BRDFs × light sets, one task
per set, each written in the DiLiGenT layout (:func:`brdfkit.vision.datasets.load_diligent`
reads it back).

Specs, as the ``brdfkit synth`` options take them:

- shape: ``sphere`` or ``sphere:PIXELS`` (a sphere filling a square image, 128 pixels by
  default), or a normal map file (:func:`brdfkit.vision.datasets.read_normal_map`: ``.png``,
  ``.npy``, ``.exr``) with its mask in ``mask.png`` beside it, or where the normal is non-zero;
- BRDF: a measured file (``.binary``, ``.bsdf``, ``.brdf``) or a model spec
  (:func:`brdfkit.brdf.parse`);
- lights: ``diligent`` (a 12 × 8 grid to 45°,
  :func:`~brdfkit.vision.datasets.diligent_like_lights`), ``grid:COLUMNSxROWS:DEGREES``, or a
  text file of ``x y z`` rows.

References
----------
.. [1] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019 (the layout).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit._array import holds_normal
from brdfkit.errors import ParameterError

MEASURED_SUFFIXES = (".binary", ".bsdf", ".brdf")
"""BRDF specs ending so are measured files."""

DEFAULT_SPHERE = 128
"""Pixels across the image of ``sphere``."""


@dataclass(frozen=True)
class SynthTask:
    """One data set: a shape, a BRDF and a light set (specs, see the module docstring);
    ``all_lit`` keeps in the mask only the pixels that every light reaches.

    Examples
    --------
    >>> SynthTask("sphere:8", "lambertian(rho=0.5)", "grid:3x2:30").folder
    'sphere_8-lambertian_rho_0.5_-grid_3x2_30-9d4c7378'
    """

    shape: str
    brdf: str
    lights: str
    all_lit: bool = False

    @property
    def folder(self) -> str:
        """The set's folder name: a readable slug of each spec and 8 hex digits of their hash."""
        specs = (self.shape, self.brdf, self.lights)
        parts = [Path(s).stem if Path(s).is_file() else s for s in specs]
        slug = "-".join(
            "".join(c if c.isalnum() or c in "._" else "_" for c in p)[:40] for p in parts
        )
        digest = hashlib.sha256(repr((self.shape, self.brdf, self.lights, self.all_lit)).encode())
        return f"{slug}-{digest.hexdigest()[:8]}"


def _sphere_pixels(spec: str) -> int:
    """The size of a ``sphere[:PIXELS]`` spec."""
    size = spec.partition(":")[2]
    try:
        pixels = int(size) if size else DEFAULT_SPHERE
    except ValueError:
        pixels = 0
    if not 8 <= pixels <= 65536:
        raise ParameterError(f"shape {spec!r}: expected sphere:PIXELS with 8 … 65536 pixels")
    return pixels


def shape_normals(spec: str) -> tuple[np.ndarray, np.ndarray]:
    """``(normals, mask)`` of a shape spec.

    Raises
    ------
    brdfkit.errors.ParameterError, brdfkit.errors.FormatError
        An unknown spec, a bad size, or an unreadable normal map or mask.

    Examples
    --------
    >>> normals, mask = shape_normals("sphere:8")
    >>> normals.shape, int(mask.sum())
    ((8, 8, 3), 32)
    """
    from brdfkit.vision import datasets
    from brdfkit.vision.photometric_stereo import sphere_normals

    if spec.partition(":")[0] == "sphere":
        pixels = _sphere_pixels(spec)
        centre = (pixels - 1) / 2
        return sphere_normals((pixels, pixels), (centre, centre), pixels / 2 - 1)
    path = Path(spec)
    if not path.is_file():
        raise ParameterError(f"shape {spec!r}: expected 'sphere[:PIXELS]' or a normal map file")
    normals = datasets.read_normal_map(path)
    if (path.parent / "mask.png").is_file():
        mask = datasets.read_mask(path.parent / "mask.png")
        if mask.shape != normals.shape[:2]:
            raise ParameterError(
                f"shape {spec!r}: mask.png is {mask.shape}, the map {normals.shape[:2]}"
            )
    else:
        mask = holds_normal(normals)
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    return np.where(mask[..., None], normals / np.where(length > 0, length, 1.0), 0.0), mask


def light_set(spec: str) -> np.ndarray:
    """``(N, 3)`` unit light directions of a light-set spec.

    Raises
    ------
    brdfkit.errors.ParameterError, brdfkit.errors.FormatError
        An unknown or malformed spec, or an unreadable file.

    Examples
    --------
    Three columns by two rows of lights, up to 30° from the view:

    >>> lights = light_set("grid:3x2:30")
    >>> lights.shape, lights[1].round(3).tolist()
    ((6, 3), [0.0, 0.25, 0.968])
    """
    from brdfkit.vision import datasets

    if spec == "diligent":
        return datasets.diligent_like_lights()
    if spec.startswith("grid:"):
        try:
            size, degrees = spec.removeprefix("grid:").split(":")
            columns, rows = (int(v) for v in size.lower().split("x"))
            return datasets.diligent_like_lights(columns, rows, np.radians(float(degrees)))
        except ValueError:
            raise ParameterError(
                f"lights {spec!r}: expected grid:COLUMNSxROWS:DEGREES, e.g. grid:12x8:45"
            ) from None
    path = Path(spec)
    if not path.is_file():
        raise ParameterError(f"lights {spec!r}: expected 'diligent', 'grid:CxR:DEG' or a file")
    lights = datasets._read_rows(path, 3)
    return datasets._unit_rows(lights, str(path))


def read_brdf(spec: str) -> Any:
    """The BRDF of a spec, a measured file, a fit.json or a BRDF Explorer file
    (:func:`brdfkit.load`).

    Examples
    --------
    >>> type(read_brdf("lambertian(rho=0.5)")).__name__
    'Lambertian'
    """
    from brdfkit.interop.load import load

    return load(spec)


def check(task: SynthTask) -> None:
    """Refuse a task whose specs do not read, before any rendering (on the client)."""
    if task.shape.partition(":")[0] == "sphere":
        _sphere_pixels(task.shape)
    elif not Path(task.shape).is_file():
        raise ParameterError(f"--shape {task.shape!r}: expected 'sphere[:PIXELS]' or a file")
    if Path(task.brdf).suffix.lower() in MEASURED_SUFFIXES:
        if not Path(task.brdf).is_file():
            raise ParameterError(f"--brdf {task.brdf!r}: no such file")
    else:
        read_brdf(task.brdf)
    light_set(task.lights)


def render(task: SynthTask) -> Any:
    """Render one set (on a worker): a :class:`~brdfkit.vision.datasets.PhotometricStereoData`
    whose ``light_intensities`` record the exposure (see
    :func:`brdfkit.vision.synthesis.synthetic_set`)."""
    from brdfkit.vision.synthesis import synthetic_set

    normals, mask = shape_normals(task.shape)
    lights = light_set(task.lights)
    if task.all_lit:
        mask = mask & np.all(normals @ lights.T > 0, axis=-1)
        if not mask.any():
            raise ParameterError(f"{task.folder}: no pixel is lit by every light")
    return synthetic_set(normals, mask, lights, read_brdf(task.brdf), name=task.folder)


def run(
    dask_client: Any, tasks: Iterable[SynthTask], on_result: Callable[[SynthTask, Any], None]
) -> None:
    """Render every task on ``dask_client``; ``on_result(task, data)`` as each finishes."""
    from brdfkit.distributed.cluster import completed

    by_key = {task.folder: task for task in tasks}
    arguments = {key: (task,) for key, task in by_key.items()}
    for key, data in completed(dask_client, render, arguments, prefix="synth"):
        on_result(by_key[key], data)
