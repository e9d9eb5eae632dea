"""``brdfkit plot``: lobe, half/difference, albedo and sphere-gallery figures as PNG/SVG."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, console, fail, shown
from brdfkit.cli._output import light_files, output_file

KINDS = ("lobe", "lobe3d", "half-diff", "albedo", "spheres")


_Kind = Annotated[str, typer.Argument(metavar="KIND", help=f"One of: {', '.join(KINDS)}.")]
_Models = Annotated[
    list[str],
    typer.Argument(
        metavar="MODEL", help="Model specs or measured files (several for albedo/spheres)."
    ),
]
_Output = Annotated[
    Path,
    typer.Option("--output", "-o", metavar="FILE", help="Output .png/.svg/.pdf."),
]
_ThetaI = Annotated[
    list[float],
    typer.Option("--theta-i", metavar="DEGREES", help="Incidence angles (degrees)."),
]
_Log = Annotated[bool, typer.Option("--log", help="Logarithmic lobe radius.")]
_Light = Annotated[
    str, typer.Option("--light", "-l", metavar="SPEC", help="Light spec for spheres.")
]
_Resolution = Annotated[int, typer.Option("--resolution", "-r", metavar="PIXELS", min=16, max=1024)]


@app.command("plot")
def plot_command(
    kind: _Kind,
    models: _Models,
    output: _Output = Path("plot.png"),
    theta_i: _ThetaI = (0.0, 30.0, 60.0),
    log: _Log = False,
    light: _Light = "envmap",
    resolution: _Resolution = 128,
) -> None:
    """Draw a BRDF the way people look at one."""
    import matplotlib

    matplotlib.use("Agg")
    from brdfkit import plot
    from brdfkit.light.spec import parse_light
    from brdfkit.report.atlas import default_cards

    if kind not in KINDS:
        fail(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    output = output_file(
        output,
        inputs=(*map(Path, models), *light_files([light])),
        suffixes=(".png", ".svg", ".pdf"),
    )
    brdfs = [examples[0] for _, examples in default_cards(models)]
    lights = parse_light(light) if kind == "spheres" else None
    thetas = [math.radians(t) for t in theta_i]
    if kind == "lobe":
        fig = plot.lobe_plot(brdfs[0], thetas, log=log)
    elif kind == "lobe3d":
        fig = plot.lobe_3d(brdfs[0], thetas[-1])
    elif kind == "half-diff":
        fig = plot.half_diff_plot(brdfs[0])
    elif kind == "albedo":
        fig = plot.albedo_plot(brdfs, labels=models)
    else:
        fig = plot.sphere_gallery(brdfs, lights, labels=models, resolution=resolution)
    plot.save(fig, output)
    console.print(f"wrote {shown(output)}")
