"""``brdfkit atlas``: the reflectance atlas, brdfkit's main job."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, console, fail, shown, status
from brdfkit.cli._output import OutputFolder

# brdfkit.report.atlas's ENV_NOISE and ENV_MAX_SAMPLES, written out so that ``--help`` imports
# no NumPy (tests/cli/test_startup.py holds them equal)
ENV_NOISE = None
ENV_MAX_SAMPLES = 2048

_Output = Annotated[Path, typer.Option("--output", "-o", metavar="FOLDER", help="Output folder.")]
_Models = Annotated[
    list[str],
    typer.Option(
        "--models",
        "-m",
        metavar="MODEL",
        help="Model specs or measured files (repeatable); default: all models.",
    ),
]
_Envmap = Annotated[
    Path | None,
    typer.Option(
        "--envmap",
        metavar="FILE",
        help="Lat-long .hdr/.exr map; default: the bundled Poly Haven map.",
    ),
]
_Resolution = Annotated[int, typer.Option("--resolution", "-r", metavar="PIXELS", min=16, max=1024)]
_Samples = Annotated[
    int,
    typer.Option(
        "--samples", "-s", metavar="N", min=1, max=4096, help="Samples per pixel (first pass)."
    ),
]
_Noise = Annotated[
    float,
    typer.Option(
        "--noise",
        metavar="REL_RMSE",
        min=0.0,
        max=1.0,
        help="Refine each environment-lit sphere until its estimated relative RMSE against a "
        "16×-spp render is below this, e.g. 0.01 (minutes); 0: every sphere at --samples.",
    ),
]
_MaxSamples = Annotated[
    int,
    typer.Option(
        "--max-samples",
        metavar="N",
        min=1,
        max=65536,
        help="Most samples per pixel of one environment-lit sphere.",
    ),
]
_Checks = Annotated[bool, typer.Option("--checks/--no-checks", help="Run the physics checks.")]
_Objects = Annotated[
    bool,
    typer.Option(
        "--objects/--no-objects",
        help="Show each model on the bundled shader ball under the map, with shadows "
        "(needs the mesh extra: pip install 'brdfkit[mesh]').",
    ),
]


@app.command("atlas")
def atlas_command(
    output: _Output = Path("atlas"),
    models: _Models = (),
    envmap: _Envmap = None,
    resolution: _Resolution = 96,
    samples: _Samples = 32,
    noise: _Noise = ENV_NOISE or 0.0,
    max_samples: _MaxSamples = ENV_MAX_SAMPLES,
    checks: _Checks = True,
    objects: _Objects = False,
) -> None:
    """Write an HTML atlas: every model's formula, spheres, lobes, albedo and physics checks."""
    import matplotlib

    matplotlib.use("Agg")
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from brdfkit.report.atlas import build_atlas

    if envmap is not None and not envmap.is_file():
        fail(f"envmap must be an existing .hdr/.exr file; got {shown(envmap)!r}")
    folder = OutputFolder(output, ("index.html",), inputs=(envmap, *map(Path, models)))
    # As cli._app.progress, but redrawn only as cards finish (no auto-refresh): rich's refresh
    # thread would leave the process with two threads, and the atlas forks its card workers
    # only from a single-threaded process (otherwise it builds every card in turn).
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=status,
        transient=True,
        disable=not status.is_terminal,
        auto_refresh=False,
    ) as bar:
        task = bar.add_task("atlas", total=None)

        def step(title: str, done: int, total: int) -> None:
            bar.update(task, description=f"atlas: {title}", completed=done, total=total)
            bar.refresh()

        path = folder.write(
            "index.html",
            lambda page: build_atlas(
                page,
                models or None,
                envmap,
                resolution=resolution,
                samples=samples,
                noise=noise or None,
                max_samples=max_samples,
                run_checks=checks,
                objects=objects,
                progress=step,
            ),
        )
    console.print(f"wrote {shown(path)}")
