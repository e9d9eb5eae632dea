"""``brdfkit separate``: diffuse/specular separation from one image or a polariser pair."""

from __future__ import annotations

from pathlib import Path

import typer

from brdfkit.cli._app import app, atomic_output, console, fail


@app.command("separate")
def separate_command(
    image: Path = typer.Argument(
        ...,
        help="Linear RGB image (.hdr/.exr, or 8/16-bit with --encoding); with --crossed, "
        "the parallel-polariser image.",
    ),
    crossed: Path | None = typer.Option(
        None, "--crossed", help="Crossed-polariser image: use the polarisation method."
    ),
    illuminant: str | None = typer.Option(
        None, "--illuminant", help="Light colour R,G,B for the dichromatic method (white)."
    ),
    encoding: str | None = typer.Option(
        None, "--encoding", help="How 8/16-bit inputs are encoded: srgb or linear."
    ),
    output: Path = typer.Option(
        Path("separation"), "--output", "-o", help="Folder for diffuse.exr and specular.exr."
    ),
) -> None:
    """Split an image into diffuse and specular reflection (dichromatic model or polarisation)."""
    import numpy as np

    from brdfkit.io import write_image
    from brdfkit.vision.calibration import read_linear_image
    from brdfkit.vision.separation import separate_dichromatic, separate_polarization

    try:
        picture = read_linear_image(image, encoding)
        if crossed is not None:
            result = separate_polarization(picture, read_linear_image(crossed, encoding))
            method = "polarisation"
        else:
            gamma = None if illuminant is None else [float(v) for v in illuminant.split(",")]
            result = separate_dichromatic(picture, gamma)
            method = "dichromatic"
    except ValueError as error:
        fail(str(error))
    with atomic_output(output) as folder:
        folder.mkdir()
        write_image(folder / "diffuse.exr", result.diffuse.astype(np.float32))
        write_image(folder / "specular.exr", result.specular.astype(np.float32))
    console.print(f"wrote {output}/ (diffuse.exr, specular.exr; {method})")
