"""``brdfkit atlas``: the reflectance atlas, brdfkit's main job."""

from __future__ import annotations

from pathlib import Path

import typer

from brdfkit.cli._app import app, console, fail


@app.command("atlas")
def atlas_command(
    output: Path = typer.Option(Path("atlas"), "--output", "-o", help="Output folder."),
    models: list[str] = typer.Option(
        [],
        "--models",
        "-m",
        help="Model specs or measured files (repeatable); default: all models.",
    ),
    envmap: Path | None = typer.Option(
        None, "--envmap", help="Lat-long .hdr/.exr map; default: the bundled Poly Haven map."
    ),
    resolution: int = typer.Option(96, "--resolution", "-r", min=16, max=1024),
    samples: int = typer.Option(32, "--samples", "-s", min=1),
    checks: bool = typer.Option(True, "--checks/--no-checks", help="Run the physics checks."),
) -> None:
    """Write an HTML atlas: every model's formula, spheres, lobes, albedo and physics checks."""
    import matplotlib

    matplotlib.use("Agg")
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from brdfkit.report import build_atlas

    if envmap is not None and not envmap.is_file():
        fail(f"envmap must be an existing .hdr/.exr file; got {str(envmap)!r}")
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as progress:
        task = progress.add_task("atlas", total=None)

        def step(title: str, done: int, total: int) -> None:
            progress.update(task, description=f"atlas: {title}", completed=done, total=total)

        try:
            path = build_atlas(
                output / "index.html",
                models or None,
                envmap,
                resolution=resolution,
                samples=samples,
                run_checks=checks,
                progress=step,
            )
        except (ValueError, FileNotFoundError) as error:
            fail(str(error))
    console.print(f"wrote {path}")
