"""The ``brdfkit`` command.

Each subcommand lives in its own module of this package and registers itself on :data:`app`;
importing the package imports them all. Modules import heavy dependencies (matplotlib, torch)
inside their command functions, so that ``brdfkit --help`` stays fast.
"""

from __future__ import annotations

import os
import signal
import sys


def _interrupted_while_starting(signum: int, frame: object) -> None:
    """Ctrl-C or SIGTERM before the command has started: nothing to clean up yet."""
    os.write(2, b"error: interrupted\n")
    os._exit(130)


if os.path.basename(sys.argv[0]) == "brdfkit":  # the console script, not a library import
    for _signal in (signal.SIGINT, signal.SIGTERM):
        signal.signal(_signal, _interrupted_while_starting)

import importlib  # noqa: E402  (after the handler: these imports take a second or two)
import inspect  # noqa: E402
import pkgutil  # noqa: E402

from brdfkit.cli._app import app, stop_on_interrupt  # noqa: E402


def _reflowed(doc: str) -> str:
    """A docstring with each paragraph on one line, for the help formatter to wrap to the
    terminal (it keeps single line breaks, which left hard-wrapped fragments)."""
    return "\n\n".join(" ".join(paragraph.split()) for paragraph in doc.split("\n\n"))


for _module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")
for _command in app.registered_commands:
    if _command.help is None and _command.callback is not None:
        _command.help = _reflowed(inspect.getdoc(_command.callback) or "")


def main() -> None:
    """Entry point of the ``brdfkit`` console script."""
    stop_on_interrupt()
    app()


__all__ = ["app", "main"]
