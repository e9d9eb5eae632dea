"""``brdfkit fit``: fit an analytic model to a measured BRDF file (MERL, RGL, Cornell); many
files × models as a batch on Dask (:mod:`brdfkit.cli._fit_batch`)."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from rich.text import Text

from brdfkit.cli._app import app, console, fail, progress, shown, status
from brdfkit.cli._output import OutputFolder

_READERS = {".binary": "read_merl", ".bsdf": "read_rgl", ".brdf": "read_cornell"}
_OUTPUTS = ("fit.json", "spheres.png")


@app.command("fit")
def fit_command(
    files: list[Path] = typer.Argument(
        ...,
        metavar="FILE...",
        help="Measured BRDF: MERL .binary, RGL .bsdf, Cornell .brdf (several: a batch).",
    ),
    models: list[str] = typer.Option(
        ["lambertian + cook_torrance"],
        "--model",
        "-m",
        metavar="SPEC",
        help="Model spec; parameters written in it stay fixed, e.g. 'lambertian + ggx'; "
        "'bivariate' (the data-driven (θh, θd) table), or 'auto' (the candidate with the "
        "least held-out error). Repeatable: a batch.",
    ),
    objective: str = typer.Option(
        "cube_root",
        "--objective",
        metavar="cube_root|log|cosine",
        help="cube_root (Forés et al. 2012), log (Löw et al. 2012, at the data's own level) or "
        "cosine (Ngan et al. 2005).",
    ),
    loss: str = typer.Option(
        "soft_l1",
        "--loss",
        metavar="NAME",
        help="soft_l1 (a few samples the model cannot follow do not decide the fit) or linear "
        "(plain least squares); also huber, cauchy, arctan.",
    ),
    loss_scale: float = typer.Option(
        0.5,
        "--loss-scale",
        metavar="X",
        help="Where the robust loss departs from least squares (relative).",
    ),
    mode: str = typer.Option(
        "shared", "--mode", metavar="shared|per_channel", help="shared or per_channel."
    ),
    starts: int = typer.Option(
        4,
        "--starts",
        metavar="N",
        min=1,
        max=64,
        help="Restarts, at most 64 (the first is the spec).",
    ),
    fix: list[str] = typer.Option(
        [], "--fix", metavar="PARAM", help="Parameter to hold fixed (repeatable)."
    ),
    output: Path | None = typer.Option(
        None,
        "--output",
        "-o",
        metavar="FOLDER",
        help="Folder for fit.json and a measured-vs-fitted sphere image.",
    ),
    resolution: int = typer.Option(128, "--resolution", "-r", metavar="PIXELS", min=16, max=2048),
    envmap: bool = typer.Option(
        False, "--envmap", help="Also render under the bundled environment map (Monte Carlo)."
    ),
    seed: int = typer.Option(
        0, "--seed", metavar="N", help="Seed of the subsets and random starts."
    ),
    as_json: bool = typer.Option(
        False, "--json", help="Print the fit (and the spheres' differences with -o) as JSON."
    ),
    workers: int | None = typer.Option(
        None,
        "--workers",
        metavar="N",
        min=1,
        help="Run as a batch on N local Dask worker processes (default: one per core).",
    ),
    scheduler: str | None = typer.Option(
        None,
        "--scheduler",
        metavar="ADDRESS",
        help="Run as a batch on the Dask cluster of this scheduler (tcp://host:8786).",
    ),
) -> None:
    """Fit a model to measured data; print the parameters and errors, optionally save renders.

    Several files or models (or --workers, --scheduler) make a batch: every file × model is a
    Dask task; -o FOLDER gets results.jsonl, results.csv and <file>-<key>/fit.json per fit, and
    a re-run skips the fits done (keyed by the file's SHA-256 and the options).
    """
    import brdfkit.measured as measured_io
    from brdfkit.fit.analytic import fit
    from brdfkit.fit.select import BIVARIATE, fit_any, select_model

    if len(files) > 1 or len(models) > 1 or workers is not None or scheduler is not None:
        from brdfkit.cli._fit_batch import run_batch

        if envmap:
            fail("--envmap renders spheres of a single fit; a batch writes fit.json only")
        options = {"objective": objective, "loss": loss, "loss_scale": loss_scale,
                   "mode": mode, "starts": starts, "fixed": sorted(fix), "seed": seed}  # fmt: skip
        run_batch(files, models, options, output, workers, scheduler, as_json)
        return
    file, model = files[0], models[0]

    if not file.is_file():
        fail(f"file {shown(file)!r} does not exist")
    reader = _READERS.get(file.suffix.lower())
    if reader is None:
        fail(f"file must end in {', '.join(_READERS)}; got {shown(file.name)!r}")
    folder = None
    if output is not None:
        folder = OutputFolder(output, _OUTPUTS, inputs=(file,))
    if model.strip() in ("auto", BIVARIATE) and fix:
        fail(f"--fix does not apply to --model {model.strip()}; got --fix {', '.join(fix)}")
    measured = getattr(measured_io, reader)(file)
    selection = None
    with progress() as bar:
        task = bar.add_task("fitting", total=1)
        options = {
            "objective": objective,
            "loss": loss,
            "loss_scale": loss_scale,
            "mode": mode,
            "starts": starts,
            "seed": seed,
            "progress": lambda done, total, text: bar.update(
                task, completed=done, total=total, description=f"fitting: {text}"
            ),
        }
        if model.strip() == "auto":
            selection = select_model(measured, **options)
            result = selection.result
        elif model.strip() == BIVARIATE:
            result = fit_any(measured, BIVARIATE, objective=objective)
        else:
            result = fit(measured, model, fixed=fix, **options)
    clamped = getattr(measured, "clamped", 0)
    if clamped:  # after the fit, so that a refused option stays the one line on stderr
        status.print(
            f"note: {clamped} values of {shown(file.name)} are negative, the format's 'not "
            "measured' marker; they evaluate to 0 and take no part in the fit"
        )
    if not as_json:
        _print_fit(file, model, objective, loss, mode, result)
        if selection is not None:
            console.print(
                f"chosen: {selection.chosen}; held-out RMS residual ({objective}): "
                + ", ".join(f"{k} {v:.4g}" for k, v in selection.held_out.items())
            )
    summary = {"file": shown(file), **result.to_dict()}
    if selection is not None:
        summary["chosen"] = selection.chosen
        summary["held_out_rms"] = selection.held_out
    if folder is not None:
        differences = _write_outputs(folder, measured, result, resolution, envmap)
        summary.update({f"delta_e_{light}": d.to_dict() for light, d in differences.items()})
        summary["output"] = shown(output)
        if not as_json:
            for light, difference in differences.items():
                console.print(
                    f"spheres under the {light} light: CIEDE2000 mean {difference.mean:.1f}, "
                    f"median {difference.median:.1f}, 95th percentile {difference.p95:.1f}"
                )
            console.print(f"wrote {shown(output)}/")
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))


def _print_fit(file: Path, model: str, objective: str, loss: str, mode: str, result) -> None:
    """The fitted parameters and errors as a table, then the spec and the run's figures."""
    import numpy as np
    from rich.table import Table

    table = Table(title=f"{shown(file.name)}: {model} ({objective}, {loss}, {mode})")
    table.add_column("parameter")
    table.add_column("value", justify="right")
    for name, value in result.params.items():
        table.add_row(name, ", ".join(f"{v:.4g}" for v in np.atleast_1d(value)))
    for name, value in result.errors.items():
        table.add_row(Text("error ", style="dim") + Text(name), f"{value:.4g}")
    console.print(table)
    console.print(f"spec: {result.spec}")
    console.print(
        f"{result.samples} samples, {result.nfev} evaluations, {result.seconds:.1f} s, "
        f"{'converged' if result.success else 'not converged'}"
    )


def _write_outputs(folder: OutputFolder, measured, result, resolution: int, envmap: bool) -> dict:
    """Write ``fit.json`` and ``spheres.png`` (measured | fitted, exposed alike; a second row
    under the environment map), the spheres' CIEDE2000 differences in the JSON; return those
    differences by light."""
    import numpy as np

    from brdfkit.data import default_envmap_path
    from brdfkit.fit.appearance import sphere_difference
    from brdfkit.io import write_image
    from brdfkit.light.environment import EnvironmentMap

    lights = {"directional": None}
    if envmap:
        lights["envmap"] = [EnvironmentMap.from_file(default_envmap_path())]
    rows, summary, differences = [], result.to_dict(), {}
    for name, light in lights.items():
        difference = sphere_difference(measured, result.model, light, resolution)
        rows.append(np.concatenate([difference.reference, difference.other], axis=1))
        summary[f"delta_e_{name}"] = difference.to_dict()
        differences[name] = difference
    text = json.dumps(summary, indent=2, allow_nan=False) + "\n"
    folder.write("fit.json", lambda path: path.write_text(text, encoding="utf-8"))
    folder.write("spheres.png", lambda path: write_image(path, np.concatenate(rows, axis=0)))
    return differences
