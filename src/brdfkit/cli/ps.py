"""``brdfkit ps``: photometric stereo on a DiLiGenT or psm folder, then normal integration."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import OutputFolder
from brdfkit.cli._ps_data import load_with_lights

if TYPE_CHECKING:
    import numpy as np
    import trimesh
    from rich.table import Table

_METHODS = ("least_squares", "trimmed", "sparse_regression", "robust_pca")
_METHODS += ("bipolynomial", "constrained_bivariate", "shared_bivariate")  # vision.bivariate
_METHODS += ("consensus",)  # vision.consensus
_INTEGRATORS = ("least_squares", "poisson_dct", "frankot_chellappa")
_OUTPUTS = (
    "normals.png", "normals.npy", "albedo.npy", "albedo.png", "depth.npy", "lights.txt",
    "mesh.ply", "angular_error.npy", "angular_error.png", "metrics.json",
)  # fmt: skip


def _choice(value: str, choices: tuple[str, ...], option: str) -> str:
    """``value`` when it is one of ``choices``; otherwise exit naming ``option``."""
    if value not in choices:
        fail(f"{option} must be one of {', '.join(choices)}; got {value!r}")
    return value


@app.command("ps")
def ps_command(
    dataset: Path = typer.Argument(
        ...,
        metavar="FOLDER",
        help="A DiLiGenT object folder (filenames.txt, ...) or a psm object folder.",
    ),
    method: str = typer.Option(
        "sparse_regression",
        "--method",
        "-m",
        metavar="METHOD",
        help=f"One of: {', '.join(_METHODS)}.",
    ),
    chrome: Path | None = typer.Option(
        None,
        "--chrome",
        metavar="FOLDER",
        help="psm chrome-sphere folder: calibrate the lights from it.",
    ),
    integration: str = typer.Option(
        "least_squares",
        "--integration",
        metavar="METHOD",
        help=f"One of: {', '.join(_INTEGRATORS)}.",
    ),
    camera: Path | None = typer.Option(
        None,
        "--camera",
        metavar="FILE",
        help="K.txt (3x3 intrinsics): perspective integration (least_squares).",
    ),
    step: int = typer.Option(
        1,
        "--step",
        metavar="N",
        min=1,
        max=64,
        help="Keep every step-th row and column (at most 64).",
    ),
    output: Path = typer.Option(
        Path("ps"), "--output", "-o", metavar="FOLDER", help="Output folder."
    ),
    as_json: bool = typer.Option(
        False, "--json", help="Print the measures and the files written as JSON."
    ),
    uncalibrated: bool = typer.Option(
        False,
        "--uncalibrated",
        help="Estimate the lights from the images (the given lights are only compared).",
    ),
    gbr_cue: str = typer.Option(
        "entropy",
        "--gbr-cue",
        metavar="CUE",
        help="With --uncalibrated: entropy or diffuse_maxima.",
    ),
    chunks: int | None = typer.Option(
        None,
        "--chunks",
        metavar="PIXELS",
        min=16,
        help="Out of core: tiles of PIXELS² on Dask, Zarr outputs (also when the stack would "
        "not fit in memory).",
    ),
) -> None:
    """Normals, albedo and depth from images under known lights; errors when ground truth exists.

    With --uncalibrated the lights are estimated from the images (Hayakawa factorisation,
    integrability, the GBR from --gbr-cue) and compared with the known ones (--chrome's or the
    data set's): lights.txt then holds the estimate.

    Writes normals.png (16-bit, n = 2 v / 65535 - 1) and normals.npy, albedo.png/.npy,
    depth.npy, mesh.ply and, with ground truth, angular_error.npy/.png (0-45° as black-white);
    lights.txt holds the light directions used; metrics.json the measures (as --json prints
    them). Frame: x right, y up, z towards the camera.
    """
    import numpy as np

    from brdfkit.cli import _ps_tiled
    from brdfkit.io import write_image
    from brdfkit.vision import datasets
    from brdfkit.vision import normal_integration as integrate
    from brdfkit.vision.metrics import angular_error, angular_error_map, depth_error
    from brdfkit.vision.uncalibrated import CUES
    from brdfkit.vision.uncalibrated import uncalibrated as solve_uncalibrated

    _choice(method, _METHODS, "--method")
    _choice(integration, _INTEGRATORS, "--integration")
    _choice(gbr_cue, CUES, "--gbr-cue")
    if _ps_tiled.wanted(dataset, chunks, step):
        refused = {
            "--chrome": chrome,
            "--camera": camera,
            "--step": step != 1,
            "--uncalibrated": uncalibrated,
        }
        _ps_tiled.run(dataset, method, integration, chunks, refused, output, as_json)
        return
    if camera is not None and integration != "least_squares":
        fail(f"--camera needs --integration least_squares, got {integration!r}")
    folder = OutputFolder(output, _OUTPUTS, inputs=(dataset, chrome, camera))
    with progress() as bar:
        task = bar.add_task("reading images", total=None)

        def advance(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        data = load_with_lights(dataset, chrome, step, advance)
        bar.update(task, description=f"{method}", completed=0, total=None)
        solver = _solvers()[method]
        extra = {} if method in ("least_squares", "trimmed") else {"callback": advance}
        if uncalibrated:
            from dataclasses import replace

            # The integrability smoothing is 1 px of the full-resolution images (see the module).
            estimate = solve_uncalibrated(
                data.images, data.mask, cue=gbr_cue, method=method, sigma=1.0 / step
            )
            cosine = np.sum(estimate.light_directions * data.light_directions, axis=1)
            light_error = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
            result = estimate.result
            data = replace(data, light_directions=estimate.light_directions)
        else:
            result = solver(data.images, data.light_directions, data.mask, **extra)
        bar.update(task, description=f"integrating ({integration})", total=None)
        intrinsics = None if camera is None else _intrinsics(camera, step)
        integrator = integrate.METHODS[integration]
        perspective = () if intrinsics is None else (intrinsics,)
        depth = integrator(result.normals, data.mask, *perspective)
    mesh = _mesh(depth, data.mask, intrinsics)
    summary: dict[str, Any] = {
        "dataset": data.name,
        "method": method,
        "integration": integration,
        "lights": len(data.images),
        "pixels": int(data.mask.sum()),
    }
    if uncalibrated:  # the lights of --chrome or of the data set, compared with the estimate
        summary["gbr_cue"] = gbr_cue
        summary["light_error_deg"] = {
            "mean": float(light_error.mean()), "median": float(np.median(light_error))
        }  # fmt: skip
    errors = None
    if data.normals is not None:
        errors = angular_error(result.normals, data.normals, data.mask)
        error_map = angular_error_map(result.normals, data.normals, data.mask)
        truth_depth = integrator(data.normals, data.mask, *perspective)
        relative = depth_error(depth, truth_depth, data.mask)["relative_rmse"]
        summary["angular_error_deg"] = errors
        summary["depth_relative_rmse"] = float(relative)
    scale = np.percentile(result.albedo[data.mask], 99) or 1.0
    albedo_shown = (result.albedo / scale).clip(0, 1).astype(np.float32)
    writes = {
        "normals.png": lambda path: datasets.write_normal_map(path, result.normals),
        "normals.npy": lambda path: np.save(path, result.normals),
        "albedo.npy": lambda path: np.save(path, result.albedo),
        "albedo.png": lambda path: write_image(path, albedo_shown),
        "depth.npy": lambda path: np.save(path, depth),
        "lights.txt": lambda path: np.savetxt(path, data.light_directions, fmt="%.8f"),
        "mesh.ply": lambda path: mesh.export(path, file_type="ply"),
    }
    if errors is not None:
        error_shown = np.nan_to_num(error_map / 45.0, nan=0.0).clip(0, 1).astype(np.float32)
        writes["angular_error.npy"] = lambda path: np.save(path, error_map)
        writes["angular_error.png"] = lambda path: write_image(path, error_shown, srgb=False)
    measures = json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
    writes["metrics.json"] = lambda path: path.write_text(measures, encoding="utf-8")
    for name, write in writes.items():
        folder.write(name, write)
    summary["output"] = shown(output)
    summary["files"] = list(writes)
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    console.print(_table(summary))
    console.print(f"wrote {shown(output)}/")


def _solvers() -> dict[str, Any]:
    """Every calibrated method by name: the Lambertian and robust ones, the non-Lambertian."""
    from brdfkit.vision import bivariate_stereo, consensus, photometric_stereo

    return {**photometric_stereo.METHODS, **bivariate_stereo.METHODS, **consensus.METHODS}


def _table(summary: dict[str, Any]) -> Table:
    """The measures of ``summary`` (what ``--json`` prints) as a table."""
    from rich.table import Table

    table = Table(title=f"{summary['dataset']}: {summary['method']}, {summary['lights']} lights")
    table.add_column("measure")
    table.add_column("value", justify="right")
    table.add_row("pixels", f"{summary['pixels']}")
    if "light_error_deg" in summary:
        table.add_row("median light error (°)", f"{summary['light_error_deg']['median']:.2f}")
    if "angular_error_deg" in summary:
        errors = summary["angular_error_deg"]
        table.add_row("mean angular error (°)", f"{errors['mean']:.2f}")
        table.add_row("median angular error (°)", f"{errors['median']:.2f}")
        relative = summary["depth_relative_rmse"]
        table.add_row("depth RMSE vs GT-normal depth", f"{100 * relative:.2f} % of range")
    return table


def _intrinsics(path: Path, step: int) -> np.ndarray:
    """The 3×3 camera matrix in ``path`` (K.txt), scaled to every ``step``-th pixel."""
    import numpy as np

    from brdfkit.errors import FormatError

    try:
        matrix = np.loadtxt(path, ndmin=2, encoding="utf-8")
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise FormatError(path, f"not a 3×3 matrix of numbers ({error})") from None
    if matrix.shape != (3, 3) or not np.isfinite(matrix).all() or matrix[2, 2] == 0:
        raise FormatError(path, f"expected a finite 3×3 camera matrix; got shape {matrix.shape}")
    return matrix * np.array([[1 / step], [1 / step], [1]])


def _mesh(depth: np.ndarray, mask: np.ndarray, camera: np.ndarray | None) -> trimesh.Trimesh:
    """A triangle mesh of the depth map: one vertex per mask pixel, two triangles per 2x2 block.

    Vertices in the camera frame (x right, y up, z towards the camera): orthographic
    ``(u, -v, -depth)`` in pixel units; perspective ``depth K^-1 (u, v, 1)`` with y and z
    flipped from OpenCV's frame. Triangles wind counter-clockwise seen from the camera.
    """
    import numpy as np
    import trimesh

    rows, columns = np.nonzero(mask)
    z = depth[mask]
    if camera is None:
        vertices = np.stack([columns, -rows, -z], axis=1).astype(np.float64)
    else:
        rays = np.stack([columns, rows, np.ones_like(columns)], axis=1) @ np.linalg.inv(camera).T
        vertices = rays * z[:, None] * np.array([1.0, -1.0, -1.0])
    index = np.full(mask.shape, -1)
    index[mask] = np.arange(len(z))
    a, b = index[:-1, :-1], index[:-1, 1:]  # top left, top right
    c, d = index[1:, :-1], index[1:, 1:]  # bottom left, bottom right
    full = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    faces = np.concatenate(
        [np.stack([a[full], c[full], b[full]], 1), np.stack([b[full], c[full], d[full]], 1)]
    )
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
