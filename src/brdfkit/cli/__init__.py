"""The ``brdfkit`` command.

Each subcommand lives in its own module of this package and registers itself on :data:`app`
when imported (:func:`load_commands`). ``brdfkit.cli.app`` is the application with every
command; the console script (:func:`main`) imports the module of the command it runs alone
(``brdfkit render …``: ``brdfkit.cli.render``), and every module for anything else (``--help``,
no command, a name that is no command's). Modules import heavy dependencies (matplotlib,
torch) inside their command functions, so that ``brdfkit --help`` stays fast.
"""

from __future__ import annotations

from brdfkit.cli._entry import guard_the_start, main

guard_the_start()  # first: a Ctrl-C while the commands load is answered as in a command

import importlib  # noqa: E402  (after the guard: these imports take a second or two)
import inspect  # noqa: E402
import pkgutil  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from typing import Any  # noqa: E402

_COMMAND_MODULES = sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name[0] != "_")
"""The modules of this package that each register a command."""


def _reflowed(doc: str) -> str:
    """A docstring with each paragraph on one line, for the help formatter to wrap to the
    terminal (it keeps single line breaks, which left hard-wrapped fragments)."""
    return "\n\n".join(" ".join(paragraph.split()) for paragraph in doc.split("\n\n"))


def load_commands(words: Sequence[str] | None = None) -> None:
    """Register the commands on :data:`app` by importing their modules: where ``words`` (a
    command line's arguments) start with a command's name (``render``, ``solid-angle``),
    that command's module alone, else (and where that module registers no command of that
    name) every module. Importing a module again does nothing."""
    from brdfkit.cli._app import app

    first = str(words[0]) if words else ""
    module = first.replace("-", "_")
    if module in _COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{module}")
    if first not in {command.name for command in app.registered_commands}:
        for name in _COMMAND_MODULES:
            importlib.import_module(f"{__name__}.{name}")
    for command in app.registered_commands:
        if command.help is None and command.callback is not None:
            command.help = _reflowed(inspect.getdoc(command.callback) or "")


def __getattr__(name: str) -> Any:
    """``app``: the application with every command registered (:func:`load_commands`)."""
    if name == "app":
        from brdfkit.cli._app import app

        load_commands()
        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["app", "load_commands", "main"]
