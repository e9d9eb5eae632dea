"""``brdfkit svbrdf``: shape and spatially varying BRDF from a photometric-stereo folder,
relighting, and the held-out relighting error against the Lambertian model
(:func:`brdfkit.vision.svbrdf_capture.capture_svbrdf`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import OutputFolder
from brdfkit.cli._ps_data import load_with_lights

if TYPE_CHECKING:
    from brdfkit.vision.svbrdf_capture import SVBRDFCapture

_OUTPUTS = (
    "normals.npy", "normals.png", "albedo.npy", "albedo.png", "weights.npy", "basis.json",
    "relit.npy", "held_out.npy",
)  # fmt: skip

_Dataset = Annotated[
    Path, typer.Argument(metavar="FOLDER", help="A DiLiGenT object folder or a psm object folder.")
]
_Chrome = Annotated[
    Path | None,
    typer.Option(
        "--chrome", metavar="FOLDER", help="psm chrome-sphere folder: calibrate the lights."
    ),
]
_Lobes = Annotated[
    str,
    typer.Option(
        "--lobes",
        "-k",
        metavar="K",
        help="Specular basis lobes: 0-4, or 'auto' (cross-validated over 0, 1, 2).",
    ),
]
_HoldOut = Annotated[
    str | None,
    typer.Option(
        "--hold-out",
        metavar="I,J,..",
        help="Fit without these images, render them and report the relighting error.",
    ),
]
_Relight = Annotated[
    Path | None,
    typer.Option("--relight", metavar="FILE", help="Light directions (N rows 'x y z') to render."),
]
_CastShadows = Annotated[
    bool,
    typer.Option(
        "--cast-shadows",
        help="Render cast shadows: the fitted normals integrated to depth, its bias chosen on "
        "the fitted images (both models of --hold-out get the same shadows).",
    ),
]
_Step = Annotated[
    int,
    typer.Option("--step", metavar="N", min=1, max=64, help="Keep every step-th row and column."),
]
_Output = Annotated[Path, typer.Option("--output", "-o", metavar="FOLDER", help="Output folder.")]
_Json = Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")]


def _indices(text: str, count: int) -> list[int]:
    """``"1,5,9"`` as image indices below ``count``; otherwise exit naming --hold-out."""
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        fail(f"--hold-out must be comma-separated image indices, e.g. 1,5,9; got {text!r}")
    if not values or len(set(values)) != len(values) or not all(0 <= v < count for v in values):
        fail(f"--hold-out must name distinct images in 0..{count - 1}; got {text!r}")
    if count - len(values) < 3:
        fail(f"--hold-out {text!r} leaves {count - len(values)} images; at least 3 are needed")
    return values


@app.command("svbrdf")
def svbrdf_command(
    dataset: _Dataset,
    chrome: _Chrome = None,
    lobes: _Lobes = "1",
    hold_out: _HoldOut = None,
    relight: _Relight = None,
    cast_shadows: _CastShadows = False,
    step: _Step = 1,
    output: _Output = Path("svbrdf"),
    as_json: _Json = False,
) -> None:
    """Normals, albedo and Ward specular lobes with per-pixel weights (Goldman et al. 2005).

    Writes normals.npy/.png, albedo.npy/.png (weights of lambertian(albedo=1)), weights.npy
    (H, W, K: weights of the Ward lobes) and basis.json (the basis spec strings); with
    --relight, relit.npy (N, H, W, C) under unit-irradiance lights; with --hold-out,
    held_out.npy (the renders of the held-out images) and their RMS error next to the
    Lambertian model's. --cast-shadows renders both with the cast shadows of the recovered
    shape (svbrdf.shadow_visibility).
    """
    from brdfkit.vision.svbrdf import MAX_LOBES
    from brdfkit.vision.svbrdf_capture import capture_svbrdf, read_light_directions

    if lobes != "auto" and lobes not in {str(k) for k in range(MAX_LOBES + 1)}:
        fail(f"--lobes must be 0 to {MAX_LOBES} or 'auto'; got {lobes!r}")
    folder = OutputFolder(output, _OUTPUTS, inputs=(dataset, chrome, relight))
    new_lights = None if relight is None else read_light_directions(relight)
    with progress() as bar:
        task = bar.add_task("reading images", total=None)
        data = load_with_lights(
            dataset, chrome, step, lambda done, total: bar.update(task, completed=done, total=total)
        )
        held = [] if hold_out is None else _indices(hold_out, len(data.images))
        capture = capture_svbrdf(
            data, lobes=lobes if lobes == "auto" else int(lobes), hold_out=held,
            relight=new_lights, cast_shadows=cast_shadows,
            progress=lambda stage: bar.update(task, description=stage, total=None),
        )  # fmt: skip
    summary = capture.summary()
    writes = _writes(capture, summary)
    for name, write in writes.items():
        folder.write(name, write)
    summary["output"] = shown(output)
    summary["files"] = list(writes)
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    _print_table(capture, summary)
    console.print(f"wrote {shown(output)}/")


def _writes(capture: SVBRDFCapture, summary: dict[str, Any]) -> dict[str, Any]:
    """Each output file's name and the function that writes it, in the order written."""
    import numpy as np

    from brdfkit.cli._previews import albedo_preview
    from brdfkit.io import write_image
    from brdfkit.vision.datasets import write_normal_map

    fit = capture.fit
    basis = json.dumps({"basis": summary["basis"], "alphas": summary["alphas"]}, indent=2)
    writes = {
        "normals.npy": lambda path: np.save(path, fit.normals),
        "normals.png": lambda path: write_normal_map(path, fit.normals),
        "albedo.npy": lambda path: np.save(path, fit.albedo),
        "albedo.png": lambda path: write_image(path, albedo_preview(fit.albedo, fit.mask)),
        "weights.npy": lambda path: np.save(path, fit.weights),
        "basis.json": lambda path: Path(path).write_text(basis, encoding="utf-8"),
    }
    if capture.relit is not None:
        writes["relit.npy"] = lambda path: np.save(path, capture.relit)
    if capture.held_out_renders is not None:
        writes["held_out.npy"] = lambda path: np.save(path, capture.held_out_renders)
    return writes


def _print_table(capture: SVBRDFCapture, summary: dict[str, Any]) -> None:
    """The lobes' roughness, the shadow bias and the held-out errors as a table."""
    from rich.table import Table

    title = f"{capture.name}: SVBRDF, {capture.lobes} lobe(s), {len(capture.train)} images"
    table = Table(title=title)
    table.add_column("measure")
    table.add_column("value", justify="right")
    table.add_row("Ward roughness", ", ".join(f"{a:.3f}" for a in capture.fit.alphas) or "-")
    if capture.shadow_bias is not None:
        table.add_row("cast-shadow bias (px)", f"{capture.shadow_bias:g}")
    if "relighting_rms" in summary:
        for model, value in summary["relighting_rms"].items():
            table.add_row(f"held-out RMS, {model}", f"{value:.4f}")
    console.print(table)
