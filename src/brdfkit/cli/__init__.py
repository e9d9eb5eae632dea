"""The ``brdfkit`` command.

Each subcommand lives in its own module of this package and registers itself on :data:`app`
when imported (:func:`~brdfkit.cli._app.load_commands`). ``brdfkit.cli.app`` is the
application with every command; the console script (:func:`main`) imports the module of the
command it runs alone (``brdfkit render …``: ``brdfkit.cli.render``), and every module for
anything else (``--help``, no command, a name that is no command's). Modules import heavy
dependencies (matplotlib, torch) inside their command functions, so that ``brdfkit --help``
stays fast.
"""

from __future__ import annotations

from brdfkit.cli._entry import guard_the_start, main

guard_the_start()  # first: a Ctrl-C while the commands load is answered as in a command

from typing import Any  # noqa: E402


def __getattr__(name: str) -> Any:
    """``app``: the application with every command registered."""
    if name == "app":
        from brdfkit.cli._app import app, load_commands

        load_commands()
        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["app", "main"]
