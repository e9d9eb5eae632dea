"""``brdfkit ps``: photometric stereo on a DiLiGenT or psm folder, then normal integration
(:func:`brdfkit.vision.reconstruction.reconstruct`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import OutputFolder
from brdfkit.cli._ps_data import load_with_lights
from brdfkit.cli.integrate import _METHODS as _INTEGRATORS

if TYPE_CHECKING:
    from rich.table import Table

    from brdfkit.vision.reconstruction import Reconstruction

_METHODS = ("least_squares", "trimmed", "sparse_regression", "robust_pca")
_METHODS += ("bipolynomial", "constrained_bivariate", "shared_bivariate")  # vision.bivariate
_METHODS += ("consensus",)  # vision.consensus
_METHODS += ("inverse_rendering",)  # vision.inverse_rendering_stereo
_OUTPUTS = (
    "normals.png", "normals.npy", "albedo.npy", "albedo.png", "depth.npy", "depth.exr",
    "lights.txt", "mesh.ply", "angular_error.npy", "angular_error.png", "metrics.json",
)  # fmt: skip

_Dataset = Annotated[
    Path,
    typer.Argument(
        metavar="FOLDER",
        help="A DiLiGenT object folder (filenames.txt, ...) or a psm object folder.",
    ),
]
_Method = Annotated[
    str | None,
    typer.Option(
        "--method",
        "-m",
        metavar="METHOD",
        help=f"One of: {', '.join(_METHODS)}; by default shared_bivariate (out of core: "
        "sparse_regression). Glossy objects: inverse_rendering (about 25 s for 96 images of "
        "612 x 512).",
        show_default=False,
    ),
]
_Chrome = Annotated[
    Path | None,
    typer.Option(
        "--chrome", metavar="FOLDER", help="psm chrome-sphere folder: calibrate the lights from it."
    ),
]
_Integration = Annotated[
    str | None,
    typer.Option(
        "--integration",
        metavar="METHOD",
        help=f"One of: {', '.join(_INTEGRATORS)}; by default bilateral_pieces, as brdfkit "
        "integrate (out of core: least squares on tiles).",
        show_default=False,
    ),
]
_Camera = Annotated[
    Path | None,
    typer.Option(
        "--camera",
        metavar="FILE",
        help="K.txt (3x3 intrinsics): perspective integration (the bilateral methods or "
        "least_squares).",
    ),
]
_Step = Annotated[
    int,
    typer.Option(
        "--step", metavar="N", min=1, max=64, help="Keep every step-th row and column (at most 64)."
    ),
]
_Output = Annotated[Path, typer.Option("--output", "-o", metavar="FOLDER", help="Output folder.")]
_Json = Annotated[
    bool, typer.Option("--json", help="Print the measures and the files written as JSON.")
]
_Uncalibrated = Annotated[
    bool,
    typer.Option(
        "--uncalibrated",
        help="Estimate the lights from the images (the given lights are only compared; a "
        "DiLiGenT folder's light_intensities.txt still divides its images as they are read).",
    ),
]
_GbrCue = Annotated[
    str,
    typer.Option(
        "--gbr-cue",
        metavar="CUE",
        help="With --uncalibrated: auto (specular where the images show highlights, else "
        "entropy), specular, equal_intensity (lights of equal or known intensity), entropy "
        "or diffuse_maxima.",
    ),
]
_Chunks = Annotated[
    int | None,
    typer.Option(
        "--chunks",
        metavar="PIXELS",
        min=16,
        help="Out of core: tiles of PIXELS² on Dask, Zarr outputs (also when the stack would "
        "not fit in memory).",
    ),
]


def _choice(value: str, choices: tuple[str, ...], option: str) -> str:
    """``value`` when it is one of ``choices``; otherwise exit naming ``option``."""
    if value not in choices:
        fail(f"{option} must be one of {', '.join(choices)}; got {value!r}")
    return value


@app.command("ps")
def ps_command(
    dataset: _Dataset,
    method: _Method = None,
    chrome: _Chrome = None,
    integration: _Integration = None,
    camera: _Camera = None,
    step: _Step = 1,
    output: _Output = Path("ps"),
    as_json: _Json = False,
    uncalibrated: _Uncalibrated = False,
    gbr_cue: _GbrCue = "auto",
    chunks: _Chunks = None,
) -> None:
    """Normals, albedo and depth from images under known lights; errors when ground truth exists.

    With --uncalibrated the lights are estimated from the images (Hayakawa factorisation, the
    ambiguity resolved by --gbr-cue: the specular highlights, or integrability and a GBR cue)
    and compared with the known ones (--chrome's or the data set's): lights.txt then holds the
    estimate. The images are read as for every method, a DiLiGenT folder's divided by its
    light_intensities.txt; the relative intensities estimated are those left over.

    Writes normals.png (16-bit, n = 2 v / 65535 - 1) and normals.npy, albedo.png/.npy,
    depth.npy and depth.exr (NaN outside the mask), mesh.ply and, with ground truth,
    angular_error.npy/.png (0-45° as black-white); lights.txt holds the light directions used;
    metrics.json the measures (as --json prints them). Frame: x right, y up, z towards the
    camera.
    """
    from brdfkit.cli import _ps_tiled
    from brdfkit.vision.depth_from_normals import PERSPECTIVE_METHODS, read_intrinsics
    from brdfkit.vision.reconstruction import DEFAULT_INTEGRATION, DEFAULT_METHOD, reconstruct
    from brdfkit.vision.uncalibrated import CUES

    if method is not None:
        _choice(method, _METHODS, "--method")
    if integration is not None:
        _choice(integration, _INTEGRATORS, "--integration")
    _choice(gbr_cue, CUES, "--gbr-cue")
    if _ps_tiled.wanted(dataset, chunks, step):
        refused = {"--chrome": chrome, "--camera": camera, "--step": step != 1,
                   "--uncalibrated": uncalibrated}  # fmt: skip
        _ps_tiled.run(dataset, method, integration, chunks, refused, output, as_json)
        return
    method, integration = method or DEFAULT_METHOD, integration or DEFAULT_INTEGRATION
    if camera is not None and integration not in PERSPECTIVE_METHODS:
        needed = " or ".join(PERSPECTIVE_METHODS)
        fail(f"--camera needs --integration {needed} (perspective); got {integration!r}")
    folder = OutputFolder(output, _OUTPUTS, inputs=(dataset, chrome, camera))
    intrinsics = None if camera is None else read_intrinsics(camera, step)
    with progress() as bar:
        task = bar.add_task("reading images", total=None)
        data = load_with_lights(
            dataset, chrome, step, lambda done, total: bar.update(task, completed=done, total=total)
        )
        surface = reconstruct(
            data, method=method, integration=integration, camera=intrinsics,
            uncalibrated=uncalibrated, gbr_cue=gbr_cue,
            sigma=1.0 / step,  # the integrability smoothing: 1 px of the full-resolution images
            progress=lambda stage, done, total: bar.update(
                task, description=stage, completed=done, total=total
            ),
        )  # fmt: skip
    writes = _writes(surface)
    for name, write in writes.items():
        folder.write(name, write)
    summary = {**surface.measures(), "output": shown(output), "files": list(writes)}
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    console.print(_table(summary))
    console.print(f"wrote {shown(output)}/")


def _writes(surface: Reconstruction) -> dict[str, Any]:
    """Each output file's name and the function that writes it, in the order written."""
    import numpy as np

    from brdfkit.cli._previews import albedo_preview, error_preview
    from brdfkit.io import write_image
    from brdfkit.vision.datasets import write_normal_map

    result, data = surface.result, surface.data
    albedo_shown = albedo_preview(result.albedo, data.mask)
    writes = {
        "normals.png": lambda path: write_normal_map(path, result.normals),
        "normals.npy": lambda path: np.save(path, result.normals),
        "albedo.npy": lambda path: np.save(path, result.albedo),
        "albedo.png": lambda path: write_image(path, albedo_shown),
        "depth.npy": lambda path: np.save(path, surface.depth),
        "depth.exr": lambda path: write_image(
            path, surface.depth.astype(np.float32), nan_marks_missing=True
        ),
        "lights.txt": lambda path: np.savetxt(path, data.light_directions, fmt="%.8f"),
        "mesh.ply": lambda path: surface.mesh.export(path, file_type="ply"),
    }
    if surface.error_map is not None:
        error_shown = error_preview(surface.error_map)
        writes["angular_error.npy"] = lambda path: np.save(path, surface.error_map)
        writes["angular_error.png"] = lambda path: write_image(path, error_shown, srgb=False)
    measures = json.dumps(surface.measures(), indent=2, ensure_ascii=False, allow_nan=False)
    writes["metrics.json"] = lambda path: path.write_text(measures + "\n", encoding="utf-8")
    return writes


def _table(summary: dict[str, Any]) -> Table:
    """The measures of ``summary`` (what ``--json`` prints) as a table."""
    from rich.table import Table

    title = f"{summary['dataset']}: {summary['method']}, {summary['lights']} lights"
    table = Table(title=f"{title}, depth by {summary['integration']}")
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
