"""The typer application that every subcommand module registers on, and how it reports errors.

Exit statuses: 0 success; 1 a check failed (``brdfkit check``); 2 bad input (a usage error, or
any :class:`~brdfkit.errors.BrdfkitError`, ``ValueError`` or ``OSError`` raised on the user's
input); 3 an internal error (a bug: please report it); 130 interrupted. Every error is one line
on standard error; user text is never read as Rich markup; set ``BRDFKIT_TRACEBACK=1`` to see the
traceback of an internal error.
"""

from __future__ import annotations

import os
import signal
import sys
import warnings
from typing import Any, NoReturn

import typer
from rich.console import Console
from rich.text import Text
from typer.core import TyperGroup

import brdfkit

BAD_INPUT = 2
"""Exit status for bad input (usage errors included, as click does)."""
CHECK_FAILED = 1
"""Exit status of a check that contradicts a claim."""
INTERNAL_ERROR = 3
"""Exit status of an unexpected failure: a bug in brdfkit."""

console = Console(markup=False, highlight=False)
"""Results (tables, "wrote …" lines) on standard output; text is never read as markup."""
status = Console(stderr=True, markup=False, highlight=False)
"""Progress bars and errors on standard error, so that standard output holds only results."""


def progress(*columns: Any) -> Any:
    """A transient progress bar on stderr (``rich.progress.Progress`` with ``columns``), shown
    only on a terminal: a pipe or a log file gets neither the bar nor the blank line it leaves."""
    from rich.progress import Progress

    return Progress(*columns, console=status, transient=True, disable=not status.is_terminal)


def shown(text: Any) -> str:
    """``text`` (a path or message) made printable: bytes that are not UTF-8 in a file name
    (carried by Python as lone surrogates) appear as ``\\xff`` escapes."""
    return str(text).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def _error_line(message: str, label: str = "error") -> None:
    line = " ".join(shown(message).split())  # one line, whatever the message held
    status.print(Text(f"{label}: ", style="bold red") + Text(line), soft_wrap=True)


def fail(message: str) -> NoReturn:
    """Print ``message`` as one error line on standard error and exit with status 2."""
    _error_line(message)
    raise typer.Exit(BAD_INPUT)


class _Group(TyperGroup):
    """The ``brdfkit`` group: turns every failure into one line on stderr and an exit status."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        with warnings.catch_warnings():
            if not sys.warnoptions:  # python -W … still shows what it asks for
                # Library warnings (NumPy's RuntimeWarnings, colour-science's notes) are noise
                # here: results are checked for NaN and errors are reported as such.
                warnings.simplefilter("ignore")
            code = _run(lambda: super(_Group, self).main(*args, standalone_mode=False, **kwargs))
        if standalone_mode:
            sys.exit(code)
        return code


def _run(call: Any) -> int:
    """Run the command line; return its exit status, having printed any error as one line."""
    from brdfkit.errors import BrdfkitError

    try:
        code = call()
    except typer.Abort:
        _error_line("aborted")
        return 130
    except typer.TyperException as error:  # click's usage errors (typer vendors click)
        hint = ""
        context = getattr(error, "ctx", None)
        if context is not None:
            hint = f" (see {context.command_path} --help)"
        message = error.format_message() if hasattr(error, "format_message") else str(error)
        _error_line(message + hint)
        return getattr(error, "exit_code", BAD_INPUT)
    except KeyboardInterrupt:
        _error_line("interrupted")
        return 130
    except MemoryError:
        _error_line("out of memory: use a smaller size option (-r, --samples, --height, …)")
        return BAD_INPUT
    except (BrdfkitError, ValueError, OSError) as error:
        if os.environ.get("BRDFKIT_TRACEBACK"):
            raise
        _error_line(str(error) or type(error).__name__)
        return BAD_INPUT
    except Exception as error:
        if os.environ.get("BRDFKIT_TRACEBACK"):
            raise
        _error_line(
            f"{type(error).__name__}: {error} (a bug in brdfkit; please report it; "
            "BRDFKIT_TRACEBACK=1 shows the traceback)",
            label="internal error",
        )
        return INTERNAL_ERROR
    return code if isinstance(code, int) else 0


app = typer.Typer(
    name="brdfkit",
    cls=_Group,
    help="The physics of appearance, computable: radiometry, BRDFs, light, rendering and "
    "physics-based vision.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


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


MODEL_HELP = (
    'a model spec ("ggx(alpha=0.2)"), a measured file (MERL .binary, RGL .bsdf, Cornell '
    ".brdf), a fit.json of brdfkit fit, or a BRDF Explorer .brdf file"
)
"""What a command's model argument may be (:func:`load_model`), for its help text."""


def load_model(source: str | os.PathLike) -> Any:
    """The BRDF a command's model argument names (:func:`brdfkit.load`): any of
    :data:`MODEL_HELP`; the loader's errors propagate as one line."""
    from brdfkit.interop.load import load

    return load(source)


def model_label(model: Any, source: str | os.PathLike) -> str:
    """How a command names a loaded model: its spec, or (data, a shader) the file's name."""
    from brdfkit.interop.load import is_file_source

    if is_file_source(source):
        return os.path.basename(os.fspath(source))
    return str(model.to_spec())


def unwind_on_termination() -> None:
    """Make SIGTERM unwind the program like an interrupt (``finally`` blocks run, so temporary
    files are removed on the way out) instead of killing it where it stands."""
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
