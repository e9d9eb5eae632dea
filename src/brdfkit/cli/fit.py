"""``brdfkit fit``: fit an analytic model to a measured BRDF file (MERL, RGL, Cornell) with
:func:`brdfkit.fit.measured_fit.fit_measured`; many files × models as a batch on Dask
(:mod:`brdfkit.cli._fit_batch`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.text import Text

from brdfkit.cli._app import app, console, fail, load_model, progress, shown, status
from brdfkit.cli._output import OutputFolder

if TYPE_CHECKING:
    from brdfkit.brdf import BRDF
    from brdfkit.fit.analytic import FitResult
    from brdfkit.fit.measured_fit import MeasuredFit

_SUFFIXES = (".binary", ".bsdf", ".brdf")
"""The measured files read: MERL, RGL, Cornell."""
_OUTPUTS = ("fit.json", "spheres.png")

_Files = Annotated[
    list[Path],
    typer.Argument(
        metavar="FILE...",
        help="Measured BRDF: MERL .binary, RGL .bsdf, Cornell .brdf (several: a batch).",
    ),
]
_Models = Annotated[
    list[str],
    typer.Option(
        "--model",
        "-m",
        metavar="SPEC",
        help="Model spec; parameters written in it stay fixed, e.g. 'lambertian + ggx'; "
        "'bivariate' (the data-driven (θh, θd) table), or 'auto' (default: the candidate with "
        "the least held-out error, reporting the best analytic and the data-driven fit; in a "
        "batch, every analytic candidate). Repeatable: a batch.",
    ),
]
_Objective = Annotated[
    str,
    typer.Option(
        "--objective",
        metavar="cube_root|log|cosine",
        help="cube_root (Forés et al. 2012), log (Löw et al. 2012, at the data's own level) or "
        "cosine (Ngan et al. 2005).",
    ),
]
_Loss = Annotated[
    str,
    typer.Option(
        "--loss",
        metavar="NAME",
        help="soft_l1 (a few samples the model cannot follow do not decide the fit) or linear "
        "(plain least squares); also huber, cauchy, arctan.",
    ),
]
_LossScale = Annotated[
    float,
    typer.Option(
        "--loss-scale",
        metavar="X",
        help="Where the robust loss departs from least squares (relative).",
    ),
]
_Mode = Annotated[
    str, typer.Option("--mode", metavar="shared|per_channel", help="shared or per_channel.")
]
_Starts = Annotated[
    int,
    typer.Option(
        "--starts", metavar="N", min=1, max=64, help="Restarts, at most 64 (the first is the spec)."
    ),
]
_Fix = Annotated[
    list[str], typer.Option("--fix", metavar="PARAM", help="Parameter to hold fixed (repeatable).")
]
_Output = Annotated[
    Path | None,
    typer.Option(
        "--output",
        "-o",
        metavar="FOLDER",
        help="Folder for fit.json and a measured-vs-fitted sphere image.",
    ),
]
_Resolution = Annotated[int, typer.Option("--resolution", "-r", metavar="PIXELS", min=16, max=2048)]
_Envmap = Annotated[
    bool,
    typer.Option("--envmap", help="Also render under the bundled environment map (Monte Carlo)."),
]
_Seed = Annotated[
    int, typer.Option("--seed", metavar="N", help="Seed of the subsets and random starts.")
]
_Json = Annotated[
    bool,
    typer.Option("--json", help="Print the fit (and the spheres' differences with -o) as JSON."),
]
_Export = Annotated[
    str | None,
    typer.Option(
        "--export",
        metavar="mitsuba|rgl|gltf|mtlx|usd",
        help="Also write the fitted model as material.<ext> into the -o folder (brdfkit "
        "export); Mitsuba gets the nearest plugin where the model has no exact one.",
    ),
]
_Workers = Annotated[
    int | None,
    typer.Option(
        "--workers",
        metavar="N",
        min=1,
        help="Run as a batch on N local Dask worker processes (default: one per core).",
    ),
]
_Scheduler = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        metavar="ADDRESS",
        help="Run as a batch on the Dask cluster of this scheduler (tcp://host:8786).",
    ),
]


@app.command("fit")
def fit_command(
    files: _Files,
    models: _Models = ("auto",),
    objective: _Objective = "cube_root",
    loss: _Loss = "soft_l1",
    loss_scale: _LossScale = 0.5,
    mode: _Mode = "shared",
    starts: _Starts = 4,
    fix: _Fix = (),
    output: _Output = None,
    resolution: _Resolution = 128,
    envmap: _Envmap = False,
    seed: _Seed = 0,
    as_json: _Json = False,
    export: _Export = None,
    workers: _Workers = None,
    scheduler: _Scheduler = None,
) -> None:
    """Fit a model to measured data; print the parameters and errors, optionally save renders.

    Several files or models (or --workers, --scheduler) make a batch: every file × model is a
    Dask task; -o FOLDER gets results.jsonl, results.csv and <file>-<key>/fit.json per fit, and
    a re-run skips the fits done (keyed by the file's SHA-256 and the options).
    """
    from brdfkit.fit.measured_fit import AUTO, fit_measured
    from brdfkit.fit.select import BIVARIATE

    options = {"objective": objective, "loss": loss, "loss_scale": loss_scale, "mode": mode,
               "starts": starts}  # fmt: skip
    if len(files) > 1 or len(models) > 1 or workers is not None or scheduler is not None:
        from brdfkit.cli._fit_batch import run_batch

        if envmap or export:
            fail("--envmap and --export take a single fit; a batch writes fit.json only")
        options.update(fixed=sorted(fix), seed=seed)  # the order of the batch's records
        run_batch(files, _batch_models(models), options, output, workers, scheduler, as_json)
        return
    file, model = files[0], models[0]
    if not file.is_file():
        fail(f"file {shown(file)!r} does not exist")
    if file.suffix.lower() not in _SUFFIXES:
        fail(f"file must end in {', '.join(_SUFFIXES)}; got {shown(file.name)!r}")
    material = None if export is None else _material_name(export, output)
    outputs = _OUTPUTS if material is None else (*_OUTPUTS, material)
    folder = None if output is None else OutputFolder(output, outputs, inputs=(file,))
    if model.strip() in (AUTO, BIVARIATE) and fix:
        fail(f"--fix does not apply to --model {model.strip()}; got --fix {', '.join(fix)}")
    data = load_model(file)  # measured data, or any BRDF a model argument may name
    with progress() as bar:
        task = bar.add_task("fitting", total=1)
        fitted = fit_measured(
            data, model, fixed=fix, seed=seed, spheres=None if folder is None else resolution,
            envmap=envmap, **options,
            progress=lambda done, total, text: bar.update(
                task, completed=done, total=total, description=f"fitting: {text}"
            ),
        )  # fmt: skip
    clamped = getattr(fitted.measured, "clamped", 0)
    if clamped:  # after the fit, so that a refused option stays the one line on stderr
        status.print(
            f"note: {clamped} values of {shown(file.name)} are negative, the format's 'not "
            "measured' marker; they evaluate to 0 and take no part in the fit"
        )
    title = f"{shown(file.name)}: {model} ({objective}, {loss}, {mode})"
    _report(file, title, fitted, folder, as_json)
    if material is not None:
        _export(fitted.result.model, export, folder, material)


def _material_name(export: str, output: Path | None) -> str:
    """``material.<ext>`` for ``--export FORMAT``, which needs ``-o``."""
    from brdfkit.interop import FORMATS, check_format

    if output is None:
        fail("--export writes material.<ext> into the -o folder; give -o FOLDER")
    return "material" + FORMATS[check_format(export)][0]


def _export(model: BRDF, export: str, folder: OutputFolder, material: str) -> None:
    """Write the fitted model as ``material`` (the nearest Mitsuba plugin, notes on stderr)."""
    from brdfkit.interop import export as write

    notes = []
    folder.write(
        material,
        lambda path: notes.extend(write(model, export, path, approximate=True).approximations),
    )
    for note in notes:
        status.print(f"note: {shown(note)}", soft_wrap=True)
    status.print(f"wrote {shown(folder.path / material)}", soft_wrap=True)


def _batch_models(models: list[str]) -> list[str]:
    """A batch's models: ``"auto"`` stands for every analytic candidate of the selection."""
    from brdfkit.fit.measured_fit import AUTO
    from brdfkit.fit.select import BIVARIATE, CANDIDATES

    analytic = [spec for spec in CANDIDATES if spec != BIVARIATE]
    expanded = [spec for m in models for spec in (analytic if m.strip() == AUTO else [m])]
    return list(dict.fromkeys(expanded))


def _report(
    file: Path, title: str, fitted: MeasuredFit, folder: OutputFolder | None, as_json: bool
) -> None:
    """Print the fit (a table titled ``title``, or JSON), write fit.json and spheres.png into
    ``folder``."""
    result, selection = fitted.result, fitted.selection
    if not as_json:
        _print_fit(title, result)
        if selection is not None:
            console.print(
                f"chosen: {selection.chosen}; held-out RMS residual ({result.objective}): "
                + ", ".join(f"{k} {v:.4g}" for k, v in selection.held_out.items())
            )
        if fitted.kinds:
            console.print(f"result: {result.spec:.60} (its spheres look closer to the data's)")
        for kind, entry in fitted.kinds_record().items():
            console.print(
                f"{kind.replace('_', '-')}: {entry['spec']}; held-out RMS residual "
                f"{entry['held_out_rms']:.4g}; spheres CIEDE2000 mean "
                f"{entry['delta_e_directional']['mean']:.1f}"
            )
    summary = {"file": shown(file), **result.to_dict()}
    if selection is not None:
        summary["chosen"] = selection.chosen
        summary["held_out_rms"] = selection.held_out
        summary.update(fitted.kinds_record())
    if folder is not None:
        _write_outputs(folder, fitted)
        summary.update({f"delta_e_{light}": d.to_dict() for light, d in fitted.spheres.items()})
        summary["output"] = shown(folder.path)
        if not as_json:
            for light, difference in fitted.spheres.items():
                console.print(
                    f"spheres under the {light} light: CIEDE2000 mean {difference.mean:.1f}, "
                    f"median {difference.median:.1f}, 95th percentile {difference.p95:.1f}"
                )
            console.print(f"wrote {shown(folder.path)}/")
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))


def _print_fit(title: str, result: FitResult) -> None:
    """The fitted parameters and errors as a table, then the spec and the run's figures."""
    import numpy as np
    from rich.table import Table

    table = Table(title=title)
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


def _write_outputs(folder: OutputFolder, fitted: MeasuredFit) -> None:
    """Write ``fit.json`` (the fit and the spheres' CIEDE2000 differences) and
    ``spheres.png`` (measured | fitted, exposed alike; a row per light)."""
    from brdfkit.io import write_image

    text = json.dumps(fitted.record(), indent=2, allow_nan=False) + "\n"
    folder.write("fit.json", lambda path: path.write_text(text, encoding="utf-8"))
    folder.write("spheres.png", lambda path: write_image(path, fitted.spheres_image()))
