"""``brdfkit svbrdf``: shape and spatially varying BRDF from a photometric-stereo folder,
relighting, and the held-out relighting error against the Lambertian model."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import OutputFolder
from brdfkit.cli._ps_data import load_with_lights

_OUTPUTS = (
    "normals.npy", "normals.png", "albedo.npy", "albedo.png", "weights.npy", "basis.json",
    "relit.npy", "held_out.npy",
)  # fmt: skip


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
    dataset: Path = typer.Argument(
        ..., metavar="FOLDER", help="A DiLiGenT object folder or a psm object folder."
    ),
    chrome: Path | None = typer.Option(
        None, "--chrome", metavar="FOLDER", help="psm chrome-sphere folder: calibrate the lights."
    ),
    lobes: str = typer.Option(
        "1",
        "--lobes",
        "-k",
        metavar="K",
        help="Specular basis lobes: 0-4, or 'auto' (cross-validated over 0, 1, 2).",
    ),
    hold_out: str | None = typer.Option(
        None,
        "--hold-out",
        metavar="I,J,..",
        help="Fit without these images, render them and report the relighting error.",
    ),
    relight: Path | None = typer.Option(
        None, "--relight", metavar="FILE", help="Light directions (N rows 'x y z') to render."
    ),
    cast_shadows: bool = typer.Option(
        False,
        "--cast-shadows",
        help="Render cast shadows: the fitted normals integrated to depth, its bias chosen on "
        "the fitted images (both models of --hold-out get the same shadows).",
    ),
    step: int = typer.Option(
        1, "--step", metavar="N", min=1, max=64, help="Keep every step-th row and column."
    ),
    output: Path = typer.Option(
        Path("svbrdf"), "--output", "-o", metavar="FOLDER", help="Output folder."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Normals, albedo and Ward specular lobes with per-pixel weights (Goldman et al. 2005).

    Writes normals.npy/.png, albedo.npy/.png (weights of lambertian(albedo=1)), weights.npy
    (H, W, K: weights of the Ward lobes) and basis.json (the basis spec strings); with
    --relight, relit.npy (N, H, W, C) under unit-irradiance lights; with --hold-out,
    held_out.npy (the renders of the held-out images) and their RMS error next to the
    Lambertian model's. --cast-shadows renders both with the cast shadows of the recovered
    shape (svbrdf.shadow_visibility).
    """
    import numpy as np

    from brdfkit.io import write_image
    from brdfkit.vision import datasets, photometric_stereo, svbrdf

    if lobes != "auto" and lobes not in {str(k) for k in range(svbrdf.MAX_LOBES + 1)}:
        fail(f"--lobes must be 0 to {svbrdf.MAX_LOBES} or 'auto'; got {lobes!r}")
    folder = OutputFolder(output, _OUTPUTS, inputs=(dataset, chrome, relight))
    new_lights = None
    if relight is not None:
        from brdfkit.errors import FormatError

        try:
            new_lights = np.loadtxt(relight, ndmin=2, encoding="utf-8")
        except (OSError, ValueError, UnicodeDecodeError) as error:
            raise FormatError(relight, f"not rows of 'x y z' numbers ({error})") from None
        if new_lights.shape[1] != 3 or not np.all(np.isfinite(new_lights)):
            raise FormatError(relight, f"expected finite rows 'x y z'; got {new_lights.shape}")
        if np.any(np.linalg.norm(new_lights, axis=1) == 0):
            raise FormatError(relight, "a light direction is zero")
    with progress() as bar:
        task = bar.add_task("reading images", total=None)

        def advance(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        data = load_with_lights(dataset, chrome, step, advance)
        lights = data.light_directions
        images = data.images.astype(np.float64)
        held = [] if hold_out is None else _indices(hold_out, len(images))
        train = [k for k in range(len(images)) if k not in held]
        scores = None
        if lobes == "auto":
            bar.update(task, description="choosing the lobes (cross-validation)", total=None)
            count, scores = svbrdf.select_lobes(images[train], lights[train], data.mask)
        else:
            count = int(lobes)
        bar.update(task, description=f"fitting {count} lobe(s)", total=None)
        fit = svbrdf.fit_svbrdf(images[train], lights[train], data.mask, lobes=count)
    summary: dict[str, Any] = {
        "dataset": data.name,
        "lobes": count,
        "alphas": [float(a) for a in fit.alphas],
        "basis": fit.basis_specs(),
        "fit_rms": fit.rms[-1] if fit.rms else None,
        "pixels": int(data.mask.sum()),
    }
    if scores is not None:
        summary["cross_validated_rms"] = {str(k): v for k, v in scores.items()}

    def visibility(directions: Any) -> Any:
        """The cast shadows of the fitted shape under ``directions``, or None."""
        if not cast_shadows:
            return None
        return svbrdf.shadow_visibility(fit.normals, data.mask, directions, bias=bias)

    if cast_shadows:
        bias, _ = svbrdf.select_shadow_bias(fit, images[train], lights[train])
        summary["shadow_bias"] = bias if math.isfinite(bias) else None  # None: no shadows
    writes = {
        "normals.npy": lambda path: np.save(path, fit.normals),
        "normals.png": lambda path: datasets.write_normal_map(path, fit.normals),
        "albedo.npy": lambda path: np.save(path, fit.albedo),
        "albedo.png": lambda path: write_image(path, _shown(fit.albedo, data.mask)),
        "weights.npy": lambda path: np.save(path, fit.weights),
        "basis.json": lambda path: Path(path).write_text(
            json.dumps({"basis": summary["basis"], "alphas": summary["alphas"]}, indent=2),
            encoding="utf-8",
        ),
    }
    if new_lights is not None:
        writes["relit.npy"] = lambda path: np.save(
            path, fit.relight(new_lights, visibility=visibility(new_lights))
        )
    if held:
        shadows = visibility(lights[held])
        rendered = fit.relight(lights[held], visibility=shadows)
        ls = photometric_stereo.least_squares(images[train], lights[train], data.mask)
        lambert = svbrdf.lambertian_relight(
            ls.albedo, ls.normals, data.mask, lights[held], visibility=shadows
        )
        real = images[held][:, data.mask]
        summary["held_out"] = held
        summary["relighting_rms"] = {
            "svbrdf": float(np.sqrt(np.mean((rendered[:, data.mask] - real) ** 2))),
            "lambertian": float(np.sqrt(np.mean((lambert[:, data.mask] - real) ** 2))),
        }
        writes["held_out.npy"] = lambda path: np.save(path, rendered)
    for name, write in writes.items():
        folder.write(name, write)
    summary["output"] = shown(output)
    summary["files"] = list(writes)
    if as_json:
        typer.echo(json.dumps(summary, indent=2, ensure_ascii=False, allow_nan=False))
        return
    from rich.table import Table

    table = Table(title=f"{data.name}: SVBRDF, {count} lobe(s), {len(train)} images")
    table.add_column("measure")
    table.add_column("value", justify="right")
    table.add_row("Ward roughness", ", ".join(f"{a:.3f}" for a in fit.alphas) or "-")
    if cast_shadows:
        table.add_row("cast-shadow bias (px)", f"{bias:g}")
    if "relighting_rms" in summary:
        for model, value in summary["relighting_rms"].items():
            table.add_row(f"held-out RMS, {model}", f"{value:.4f}")
    console.print(table)
    console.print(f"wrote {shown(output)}/")


def _shown(albedo: Any, mask: Any) -> Any:
    """The albedo scaled by its 99th percentile over the mask, in [0, 1], for a PNG."""
    import numpy as np

    scale = np.percentile(albedo[mask], 99) or 1.0
    return (albedo / scale).clip(0, 1).astype(np.float32)
