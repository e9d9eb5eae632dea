"""``brdfkit materials``: the named real-material presets (published fits to MERL), with their
fits, models and sources."""

from __future__ import annotations

import json

import typer
from rich.text import Text

from brdfkit.cli._app import app, console, fail


@app.command("materials")
def materials_command(
    fit: str | None = typer.Option(
        None,
        "--fit",
        metavar="FIT",
        help="Keep one fit (e.g. ngan_ward, low_lowsmooth_E2, bagher_sgd).",
    ),
    model: str | None = typer.Option(
        None,
        "--model",
        metavar="TEXT",
        help="Keep the fits whose name or bbm model contains this text (e.g. ward, cook).",
    ),
    as_json: bool = typer.Option(
        False, "--json", help="Print the presets as JSON (with specs and citations)."
    ),
) -> None:
    """List the real-material presets: each MERL material as fitted by a published model, for
    specs such as brdfkit render "material(name='alum-bronze', fit='ngan_ward')"."""
    from brdfkit.materials import catalogue, citation, fits

    if fit is not None and fit not in fits():
        fail(f"--fit: unknown fit {fit!r}; expected one of {', '.join(fits())}")
    records = catalogue(fit=fit, model=model)
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
