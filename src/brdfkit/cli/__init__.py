"""The ``brdfkit`` command.

Each subcommand lives in its own module of this package and registers itself on :data:`app`;
importing the package imports them all. Modules import heavy dependencies (matplotlib, torch)
inside their command functions, so that ``brdfkit --help`` stays fast.
"""

from __future__ import annotations

import importlib
import pkgutil

from brdfkit.cli._app import app, unwind_on_termination

for _module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")


def main() -> None:
    """Entry point of the ``brdfkit`` console script."""
    unwind_on_termination()
    app()


__all__ = ["app", "main"]
