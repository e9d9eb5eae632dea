"""The typer application that every subcommand module registers on, and shared CLI helpers."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import typer
from rich.console import Console

import brdfkit

app = typer.Typer(
    name="brdfkit",
    help="The physics of appearance, computable: radiometry, BRDFs, light, rendering and "
    "physics-based vision.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()


def _version(value: bool) -> None:
    if value:
        console.print(f"brdfkit {brdfkit.__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """brdfkit: radiometry, reflectance, light, rendering and physics-based vision."""


def fail(message: str) -> None:
    """Print ``message`` as an error and exit with status 2 (bad input)."""
    console.print(f"[bold red]error:[/] {message}")
    raise typer.Exit(2)


@contextmanager
def atomic_output(path: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    Works for a file or a folder: nothing is ever left half-written at ``path``. On failure the
    temporary is removed and ``path`` is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    target = tmp / path.name
    try:
        yield target
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        os.replace(target, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
