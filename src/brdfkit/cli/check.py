"""``brdfkit check MODEL_SPEC``: measure a model's physics and compare it with its claims."""

from __future__ import annotations

import json
from typing import Annotated

import typer
from rich.text import Text

from brdfkit.cli._app import CHECK_FAILED, MODEL_HELP, app, console, load_model, status

_Spec = Annotated[
    str,
    typer.Argument(
        metavar="MODEL",
        help=f'The model: {MODEL_HELP}; e.g. "lambertian(albedo=0.8) + ggx(alpha=0.2)".',
    ),
]
_Json = Annotated[bool, typer.Option("--json", help="Print the report as JSON.")]
_Seed = Annotated[
    int,
    typer.Option(metavar="N", help="Seed of the random directions and Monte Carlo samples."),
]


@app.command("check")
def check_command(spec: _Spec, as_json: _Json = False, seed: _Seed = 0) -> None:
    """Check reciprocity, energy conservation, isotropy, non-negativity and sampling.

    Exits with 0 when every measurement agrees with what the model claims (a model may claim
    not to be reciprocal, as the original Phong model does), 1 when a check contradicts a
    claim, 2 on a bad spec and 3 on an internal error.
    """
    from brdfkit.checks.properties import check

    brdf = load_model(spec)
    with status.status("checking…") as spinner:
        report = check(brdf, seed=seed, progress=lambda name: spinner.update(f"checking {name}…"))
    if as_json:
        typer.echo(json.dumps(report.to_dict(), indent=2, ensure_ascii=False))
    else:
        console.print(report.to_table())
        if report.consistent:
            console.print(Text("every measurement agrees with the model's claims", "green"))
        else:
            names = ", ".join(r.name for r in report.contradictions)
            console.print(Text("measurements contradict the model's claims: ", "bold red") + names)
    if not report.consistent:
        raise typer.Exit(CHECK_FAILED)
