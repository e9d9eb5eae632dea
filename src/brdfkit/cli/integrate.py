"""``brdfkit integrate``: depth and a mesh from a normal map."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import OutputFolder

_METHODS = (
    "bilateral_pieces",
    "bilateral_continuity",
    "bilateral",
    "least_squares",
    "poisson_dct",
    "frankot_chellappa",
)
"""The keys of :data:`brdfkit.vision.depth_from_normals.METHODS` (kept here so that
``--help`` needs no NumPy)."""
_OUTPUTS = ("depth.npy", "depth.exr", "mesh.ply")

_Normals = Annotated[
    Path,
    typer.Argument(
        metavar="NORMALS",
        help="A normal-map image (or .npy), or a folder with normal_map.png, mask.png, K.txt.",
    ),
]
_Mask = Annotated[
    Path | None,
    typer.Option(
        "--mask",
        metavar="FILE",
        help="Object mask image (white = object); without one, the pixels holding a normal "
        "(longer than 1/2: a background of zeros or mid-grey is left out).",
    ),
]
_Camera = Annotated[
    Path | None,
    typer.Option("--K", "-K", metavar="FILE", help="3x3 intrinsics K (text): perspective."),
]
_Method = Annotated[
    str,
    typer.Option("--method", "-m", metavar="METHOD", help=f"One of: {', '.join(_METHODS)}."),
]
_Output = Annotated[
    Path,
    typer.Option(
        "--output", "-o", metavar="FOLDER", help="Folder for depth.npy, depth.exr and mesh.ply."
    ),
]
_Prior = Annotated[
    Path | None,
    typer.Option(
        "--prior",
        metavar="FILE",
        help="Depth known in places (.npy or .exr, NaN where unknown; with K in any unit, the "
        "result's, else in pixels), e.g. from a depth sensor: sets the scale (offset) the "
        "normals leave open. Bilateral methods only.",
    ),
]
_PriorWeight = Annotated[
    float,
    typer.Option(
        "--prior-weight",
        metavar="W",
        help="Each known depth's weight (> 0) as a fraction of a typical normal equation's.",
    ),
]
_Json = Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")]


@app.command("integrate")
def integrate_command(
    normals: _Normals,
    mask: _Mask = None,
    camera: _Camera = None,
    method: _Method = "bilateral_pieces",
    prior: _Prior = None,
    prior_weight: _PriorWeight = 0.01,
    output: _Output = Path("integrate"),
    as_json: _Json = False,
) -> None:
    """Integrate a normal map into depth, keeping depth discontinuities.

    The default, bilateral_pieces, is bilateral normal integration (Cao et al. 2022) with the
    relative scale of the pieces its weights part (which the normals leave open) taken from the
    least-squares surface; bilateral_continuity pulls weakly towards that surface instead;
    bilateral is the authors' method alone. With --prior the known depths set the scale of
    the pieces they fall on, and the depth is in the prior's units.

    Normal maps are encoded as n = 2 v / v_max - 1 per channel, red = x (right), green = y
    (up), blue = z (towards the camera). A folder may hold mask.png and K.txt, which --mask and
    --K replace. Writes depth.npy and depth.exr (depth along the optical axis, NaN outside the
    mask: pixel units without K, up to scale with it) and mesh.ply.
    """
    import numpy as np

    from brdfkit.io import write_image
    from brdfkit.vision.depth_from_normals import integrate_normal_file

    if method not in _METHODS:
        fail(f"--method must be one of {', '.join(_METHODS)}; got {method!r}")
    folder = OutputFolder(output, _OUTPUTS, inputs=(normals, mask, camera, prior))
    with progress() as bar:
        task = bar.add_task(f"integrating ({method})", total=None)
        surface = integrate_normal_file(
            normals, mask, camera, method, prior=prior, prior_weight=prior_weight,
            callback=lambda done, total: bar.update(task, completed=done, total=total),
        )  # fmt: skip
    mesh = surface.mesh
    folder.write("depth.npy", lambda path: np.save(path, surface.depth))
    folder.write(
        "depth.exr",
        lambda path: write_image(path, surface.depth.astype(np.float32), nan_marks_missing=True),
    )
    folder.write("mesh.ply", lambda path: mesh.export(path, file_type="ply"))
    summary = {**surface.summary(), "output": shown(output), "files": list(_OUTPUTS)}
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    known = f", {surface.prior_depths} known depths" if prior is not None else ""
    console.print(
        f"wrote {shown(output)}/ ({summary['projection']} depth of {summary['pixels']} pixels, "
        f"{method}{known})"
    )
