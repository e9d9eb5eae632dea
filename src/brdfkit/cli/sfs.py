"""``brdfkit sfs``: shape from shading of a Lambertian object under a known distant light."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, console, fail, shown
from brdfkit.cli._output import OutputFolder

_OUTPUTS = ("depth.npy", "normals.npy", "normals.png")


_Image = Annotated[
    Path,
    typer.Argument(metavar="IMAGE", help="Linear .hdr/.exr (or 8/16-bit with --encoding)."),
]
_Light = Annotated[
    str,
    typer.Option("--light", "-l", metavar="X,Y,Z", help="Direction towards the light: X,Y,Z."),
]
_Mask = Annotated[
    Path | None,
    typer.Option("--mask", metavar="FILE", help="Object mask image (white = object)."),
]
_Encoding = Annotated[
    str | None,
    typer.Option(
        "--encoding",
        metavar="srgb|linear",
        help="How an 8/16-bit input is encoded: srgb or linear.",
    ),
]
_Step = Annotated[
    int,
    typer.Option(
        "--step",
        metavar="N",
        min=1,
        max=64,
        help="Average step × step pixel blocks first (at most 64).",
    ),
]
_Smoothness = Annotated[
    float,
    typer.Option("--smoothness", metavar="LAMBDA", min=0.0, help="Smoothness weight λ."),
]
_Output = Annotated[
    Path,
    typer.Option(
        "--output",
        "-o",
        metavar="FOLDER",
        help="Folder for depth.npy, normals.npy and normals.png.",
    ),
]


@app.command("sfs")
def sfs_command(
    image: _Image,
    light: _Light,
    mask: _Mask = None,
    encoding: _Encoding = None,
    step: _Step = 1,
    smoothness: _Smoothness = 1e-4,
    output: _Output = Path("sfs"),
) -> None:
    """Recover depth and normals from one image (Horn's variational shape from shading)."""
    import numpy as np

    from brdfkit.io import write_image
    from brdfkit.vision.calibration import read_linear_image
    from brdfkit.vision.datasets import read_mask
    from brdfkit.vision.shape_from_shading import shape_from_shading

    try:
        direction = np.array([float(v) for v in light.split(",")])
    except ValueError:
        fail(f"--light must be three numbers X,Y,Z; got {light!r}")
    folder = OutputFolder(output, _OUTPUTS, inputs=(image, mask))
    picture = read_linear_image(image, encoding).mean(axis=-1)
    m = np.ones(picture.shape, bool) if mask is None else read_mask(mask)
    if m.shape != picture.shape:
        fail(f"--mask has shape {m.shape}, the image {picture.shape}: they must match")
    h, w = (picture.shape[0] // step) * step, (picture.shape[1] // step) * step
    if h == 0 or w == 0:
        fail(f"--step {step} is larger than the image ({picture.shape[1]}×{picture.shape[0]})")
    picture = picture[:h, :w].reshape(h // step, step, w // step, step).mean(axis=(1, 3))
    m = m[:h, :w].reshape(h // step, step, w // step, step).all(axis=(1, 3))
    result = shape_from_shading(picture, direction, m, smoothness=smoothness)
    shown_normals = (result.normals + 1) / 2 * m[..., None]
    folder.write("depth.npy", lambda path: np.save(path, result.depth))
    folder.write("normals.npy", lambda path: np.save(path, result.normals))
    folder.write("normals.png", lambda path: write_image(path, shown_normals, srgb=False))
    console.print(
        f"wrote {shown(output)}/ (depth, normals; {result.iterations} iterations, "
        f"relative brightness RMS {result.rms:.4f})"
    )
