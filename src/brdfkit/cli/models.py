"""``brdfkit models``: the registered reflectance models, their parameters and physics claims."""

from __future__ import annotations

import dataclasses
import json
import re
import textwrap
from typing import Annotated, Any

import typer
from rich.text import Text

from brdfkit.cli._app import app, console

_CLAIMS = ("reciprocal", "energy_conserving", "isotropic", "has_delta", "transmits")
_CLAIM_WORDS = {
    "reciprocal": ("reciprocal", "not reciprocal"),
    "energy_conserving": ("energy-conserving", "not energy-conserving"),
    "isotropic": ("isotropic", "anisotropic"),
    "has_delta": ("delta lobes", None),
    "transmits": ("transmits", None),
}
"""How each claim reads when true and when false (``None``: not worth a word)."""
_ROLE = re.compile(r":\w+:`([^`]*)`")
"""A reStructuredText role such as :math:`x` (shown as its content)."""
_INDENT = "  "
"""The indent of a model's parameter lines, under its name."""


def _number(x: float) -> str:
    """``x`` in at most four significant digits, exponents written short (``1e6``)."""
    mantissa, _, exponent = f"{x:.4g}".partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else mantissa


def interval(domain: Any) -> str:
    """A domain as an interval, ``[0, 1]`` or ``(0, 1e6]``."""
    left = "(" if domain.lo_open else "["
    right = ")" if domain.hi_open else "]"
    return f"{left}{_number(domain.lo)}, {_number(domain.hi)}{right}"


def model_table() -> list[dict[str, Any]]:
    """One record per registered model: spec name, class, summary, parameters (defaults as
    spec text), their domains, and the claims."""
    from brdfkit.brdf import MODELS
    from brdfkit.brdf.base import spec_value
    from brdfkit.params import parameter_domains

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
            parameters[f.name] = None if default is None else spec_value(default)
        domains = {
            key: {**dataclasses.asdict(domain), "interval": interval(domain)}
            for key, domain in parameter_domains(cls).items()
        }
        doc = _ROLE.sub(r"\1", cls.__doc__ or "").strip().splitlines()
        records.append(
            {
                "name": name,
                "class": f"{cls.__module__}.{cls.__qualname__}",
                "summary": doc[0] if doc else "",
                "parameters": parameters,
                "domains": domains,
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


def _claims_text(claims: dict[str, bool | None]) -> str:
    """The claims in words: ``reciprocal, not energy-conserving, isotropic``."""
    words = []
    for claim, value in claims.items():
        true, false = _CLAIM_WORDS[claim]
        if value is None:
            words.append(f"{true}?")
        elif value or false is not None:
            words.append(true if value else false)
    return ", ".join(words)


def _parameter_entries(record: dict[str, Any]) -> list[str]:
    """``name=default ∈ domain`` per parameter (``name ∈ domain`` for an optional one)."""
    entries = []
    for name, default in record["parameters"].items():
        entry = name if default is None else f"{name}={default}"
        domain = record["domains"].get(name)
        entries.append(entry if domain is None else f"{entry} ∈ {domain['interval']}")
    return entries


def _packed(entries: list[str], width: int) -> list[str]:
    """``entries`` joined by ``"; "`` into indented lines of at most ``width`` columns, never
    breaking an entry (one longer than a line gets a line of its own)."""
    lines: list[str] = []
    for entry in entries:
        if lines and len(lines[-1]) + 2 + len(entry) + 1 <= width:
            lines[-1] += f"; {entry}"
        else:
            if lines:
                lines[-1] += ";"
            lines.append(_INDENT + entry)
    return lines


def model_block(record: dict[str, Any], width: int) -> list[Text]:
    """A model as a few lines of at most ``width`` columns: its name and claims, then its
    parameters with their defaults and domains; no word or parameter is broken."""
    name = record["name"]
    head = textwrap.wrap(
        f"{name}  {_claims_text(record['claims'])}",
        width,
        subsequent_indent=_INDENT,
        break_long_words=False,
        break_on_hyphens=False,
    )
    lines = [Text(name, style="bold") + Text(head[0][len(name) :])]
    lines += [Text(line) for line in head[1:] + _packed(_parameter_entries(record), width)]
    return lines


_Json = Annotated[
    bool,
    typer.Option("--json", help="Print the list as JSON (with classes, summaries and domains)."),
]


@app.command("models")
def models_command(as_json: _Json = False) -> None:
    """List the registered models: their physics claims, and their parameters with defaults
    and domains."""
    records = model_table()
    if as_json:
        typer.echo(json.dumps(records, indent=2, ensure_ascii=False))
        return
    legend = (
        'Models for specs such as brdfkit check "ggx(alpha=0.3)": each name with its claims, '
        "then parameter=default ∈ domain (no default: optional)."
    )
    for line in textwrap.wrap(legend, console.width):
        console.print(Text(line, style="dim"))
    for record in records:
        for line in model_block(record, console.width):
            console.print(line, no_wrap=True, overflow="ignore")
