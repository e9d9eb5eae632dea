"""``brdfkit export SOURCE --to FORMAT -o FILE``: a model or measured BRDF as a Mitsuba 3, RGL,
glTF, MaterialX or USD file (:func:`brdfkit.interop.export`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import MODEL_HELP, app, console, load_model, shown, status
from brdfkit.cli._output import output_file

_FORMATS = "mitsuba|rgl|gltf|mtlx|usd"

_Source = Annotated[
    str,
    typer.Argument(
        metavar="SOURCE",
        help=MODEL_HELP + ".",
    ),
]
_To = Annotated[str, typer.Option("--to", "-t", metavar=_FORMATS, help="The format to write.")]
_Output = Annotated[
    Path,
    typer.Option(
        "--output",
        "-o",
        metavar="FILE",
        help="The file: .xml (mitsuba), .bsdf (rgl), .gltf/.glb, .mtlx, .usda/.usd/.usdc.",
    ),
]
_Approximate = Annotated[
    bool,
    typer.Option(
        "--approximate",
        help="mitsuba: export the nearest plugin where an option has no exact counterpart "
        "(say, height-correlated masking) instead of refusing; the differences are printed.",
    ),
]


@app.command("export")
def export_command(
    source: _Source, to: _To, output: _Output, approximate: _Approximate = False
) -> None:
    """Write a model or measured BRDF for another tool: Mitsuba 3 (<bsdf> XML), an RGL .bsdf
    table (Mitsuba's 'measured' plugin), glTF 2.0, MaterialX (OpenPBR) or USD
    (UsdPreviewSurface). What a format cannot express is refused by name; the glTF, MaterialX
    and USD materials are approximations, which are printed.
    """
    from brdfkit.interop import check_format, export

    fmt = check_format(to, output)
    output = output_file(output, inputs=(Path(source),), option="--output")
    brdf = load_model(source)
    with status.status(f"writing {to}…"):
        done = export(brdf, fmt, output, approximate=approximate)
    for note in done.approximations:
        status.print(f"note: {shown(note)}", soft_wrap=True)
    console.print(f"wrote {shown(done.path)}")
