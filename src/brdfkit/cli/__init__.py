"""The ``brdfkit`` command.

Each subcommand lives in its own module of this package and registers itself on :data:`app`;
importing the package imports them all. Modules import heavy dependencies (matplotlib, torch)
inside their command functions, so that ``brdfkit --help`` stays fast.
"""

from __future__ import annotations

from brdfkit.cli._entry import guard_the_start, main

guard_the_start()  # first: a Ctrl-C while the commands load is answered as in a command

import importlib  # noqa: E402  (after the guard: these imports take a second or two)
import inspect  # noqa: E402
import pkgutil  # noqa: E402

from brdfkit.cli._app import app  # noqa: E402


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


__all__ = ["app", "main"]
