"""``brdfkit models``: the registered reflectance models, their parameters and physics claims."""

from __future__ import annotations

import dataclasses
import json
import re
from typing import Any

import typer
from rich.text import Text

from brdfkit.cli._app import app, console

_CLAIMS = ("reciprocal", "energy_conserving", "isotropic", "has_delta", "transmits")
_ROLE = re.compile(r":\w+:`([^`]*)`")
"""A reStructuredText role such as :math:`x` (shown as its content)."""
_MARKS = {True: Text("yes", "green"), False: Text("no", "dim"), None: Text("?")}
_HEADERS = {
    "reciprocal": "recip-\nrocal",
    "energy_conserving": "energy\nconserv.",
    "isotropic": "iso-\ntropic",
    "has_delta": "has\ndelta",
    "transmits": "trans-\nmits",
}
"""Two-line claim headers, so that the yes/no columns stay narrow."""
_WIDE = 140
"""Terminal width from which the models' one-line summaries are shown too."""


def model_table() -> list[dict[str, Any]]:
    """One record per registered model: spec name, class, summary, parameters, claims."""
    from brdfkit.brdf import MODELS
    from brdfkit.brdf.base import _spec_value

    records = []
    for name, cls in sorted(MODELS.items()):
        parameters = {}
        for f in dataclasses.fields(cls):
            if not f.init:
                continue
            if f.default is not dataclasses.MISSING:
                default = f.default
            elif f.default_factory is not dataclasses.MISSING:
                default = f.default_factory()
            else:
                default = None
            parameters[f.name] = None if default is None else _spec_value(default)
        doc = _ROLE.sub(r"\1", cls.__doc__ or "").strip().splitlines()
        records.append(
            {
                "name": name,
                "class": f"{cls.__module__}.{cls.__qualname__}",
                "summary": doc[0] if doc else "",
                "parameters": parameters,
                "claims": {claim: _claim(cls, claim) for claim in _CLAIMS},
            }
        )
    return records


def _claim(cls: type, claim: str) -> bool | None:
    """A class-level claim; one computed per instance is read off the default instance
    (``None`` when that cannot be built)."""
    value = getattr(cls, claim)
    if not isinstance(value, property):
        return bool(value)
    try:
        return bool(getattr(cls(), claim))
    except (TypeError, ValueError):
        return None


@app.command("models")
def models_command(
    as_json: bool = typer.Option(False, "--json", help="Print the list as JSON."),
) -> None:
    """List the registered models with their parameters (and defaults) and physics claims."""
    from rich.table import Table

    records = model_table()
    if as_json:
        typer.echo(json.dumps(records, indent=2, ensure_ascii=False))
        return
    table = Table(
        title='registered models (use them in specs: brdfkit check "name(param=…)")',
        title_justify="left",
    )
    table.add_column("model", style="bold", no_wrap=True)
    table.add_column("parameters (defaults)", overflow="fold")
    for claim in _CLAIMS:
        table.add_column(_HEADERS[claim], justify="center", no_wrap=True)
    wide = console.width >= _WIDE
    if wide:
        table.add_column("summary", overflow="fold")
    for record in records:
        params = ", ".join(f"{k}={v}" for k, v in record["parameters"].items())
        marks = [_MARKS[record["claims"][c]] for c in _CLAIMS]
        table.add_row(record["name"], params, *marks, *([record["summary"]] if wide else []))
    console.print(table)
    if not wide:
        console.print(
            Text(f"(a terminal {_WIDE} columns wide shows each model's summary too)", "dim")
        )
