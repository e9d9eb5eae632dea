"""``brdfkit materials``: the named real-material presets (published fits to MERL), with their
fits, models and sources."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.text import Text

from brdfkit.cli._app import app, console, fail, progress, shown

_Fit = Annotated[
    str | None,
    typer.Option(
        "--fit",
        metavar="FIT",
        help="Keep one fit (e.g. ngan_ward, low_lowsmooth_E2, bagher_sgd).",
    ),
]
_Model = Annotated[
    str | None,
    typer.Option(
        "--model",
        metavar="TEXT",
        help="Keep the fits whose name or bbm model contains this text (e.g. ward, cook).",
    ),
]
_Json = Annotated[
    bool,
    typer.Option("--json", help="Print the presets as JSON (with specs and citations)."),
]
_Gallery = Annotated[
    Path | None,
    typer.Option(
        "--gallery",
        metavar="OUT.html",
        help="Write a page with one small sphere per preset kept (a few seconds for all).",
    ),
]


@app.command("materials")
def materials_command(
    fit: _Fit = None,
    model: _Model = None,
    as_json: _Json = False,
    gallery: _Gallery = None,
) -> None:
    """List the real-material presets: each MERL material as fitted by a published model, for
    specs such as brdfkit render "material(name='alum-bronze', fit='ngan_ward')"."""
    from brdfkit.brdf.presets import catalogue, citation, fits

    if fit is not None and fit not in fits():
        fail(f"--fit: unknown fit {fit!r}; expected one of {', '.join(fits())}")
    records = catalogue(fit=fit, model=model)
    if gallery is not None:
        _write_gallery(gallery, fit, model, len(records))
        return
    if as_json:
        typer.echo(json.dumps(records, indent=2, ensure_ascii=False))
        return
    if not records:
        console.print(Text(f"no presets match --model {model!r}", style="dim"))
        return
    for key in dict.fromkeys(r["fit"] for r in records):
        chosen = [r["name"] for r in records if r["fit"] == key]
        console.print(Text(f"{key}", style="bold") + Text(f"  ({len(chosen)}) {citation(key)}"))
        console.print(Text("  " + ", ".join(chosen)), soft_wrap=False)


def _write_gallery(path: Path, fit: str | None, model: str | None, count: int) -> None:
    from brdfkit.cli._output import output_file
    from brdfkit.io import atomic_write_bytes
    from brdfkit.report.gallery import gallery_html

    path = output_file(path, option="--gallery", suffixes=(".html", ".htm"))
    if count == 0:
        fail(f"--model: no presets match {model!r}; nothing to draw")
    with progress() as bar:
        task = bar.add_task("spheres", total=count)
        page = gallery_html(fit, model, progress=lambda done, _: bar.update(task, completed=done))
    atomic_write_bytes(path, page.encode("utf-8"))
    console.print(f"wrote {shown(path)} ({count} presets)")
