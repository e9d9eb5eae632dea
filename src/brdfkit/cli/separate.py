"""``brdfkit separate``: diffuse/specular separation from one image or a polariser pair."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, console, fail, shown
from brdfkit.cli._output import OutputFolder

_Image = Annotated[
    Path,
    typer.Argument(
        metavar="IMAGE",
        help="Linear RGB image (.hdr/.exr, or 8/16-bit with --encoding); with --crossed, "
        "the parallel-polariser image.",
    ),
]
_Crossed = Annotated[
    Path | None,
    typer.Option(
        "--crossed",
        metavar="IMAGE",
        help="Crossed-polariser image: use the polarisation method.",
    ),
]
_Illuminant = Annotated[
    str | None,
    typer.Option(
        "--illuminant",
        metavar="R,G,B",
        help="Light colour R,G,B for the dichromatic method (white).",
    ),
]
_Encoding = Annotated[
    str | None,
    typer.Option(
        "--encoding",
        metavar="srgb|linear",
        help="How 8/16-bit inputs are encoded: srgb or linear.",
    ),
]
_Output = Annotated[
    Path,
    typer.Option(
        "--output",
        "-o",
        metavar="FOLDER",
        help="Folder for diffuse.exr and specular.exr.",
    ),
]


@app.command("separate")
def separate_command(
    image: _Image,
    crossed: _Crossed = None,
    illuminant: _Illuminant = None,
    encoding: _Encoding = None,
    output: _Output = Path("separation"),
) -> None:
    """Split an image into diffuse and specular reflection (dichromatic model or polarisation)."""
    import numpy as np

    from brdfkit.io import write_image
    from brdfkit.vision.calibration import read_linear_image
    from brdfkit.vision.separation import separate_dichromatic, separate_polarization

    folder = OutputFolder(output, ("diffuse.exr", "specular.exr"), inputs=(image, crossed))
    picture = read_linear_image(image, encoding)
    if crossed is not None:
        result = separate_polarization(picture, read_linear_image(crossed, encoding))
        method = "polarisation"
    else:
        gamma = None if illuminant is None else _colour(illuminant)
        result = separate_dichromatic(picture, gamma)
        method = "dichromatic"
    folder.write("diffuse.exr", lambda path: write_image(path, result.diffuse.astype(np.float32)))
    folder.write("specular.exr", lambda path: write_image(path, result.specular.astype(np.float32)))
    console.print(f"wrote {shown(output)}/ (diffuse.exr, specular.exr; {method})")


def _colour(text: str) -> list[float]:
    """The light colour R,G,B of ``--illuminant``."""
    try:
        colour = [float(v) for v in text.split(",")]
    except ValueError:
        colour = []
    if len(colour) != 3:
        fail(f"--illuminant must be three numbers R,G,B; got {text!r}")
    return colour
