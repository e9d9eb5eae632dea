"""The typer application that every subcommand module registers on, and how it reports errors.

Exit statuses: 0 success; 1 a check failed (``brdfkit check``); 2 bad input (a usage error, or
any :class:`~brdfkit.errors.BrdfkitError`, ``ValueError`` or ``OSError`` raised on the user's
input) or an optional part whose extra is not installed
(:class:`~brdfkit.errors.MissingExtraError`, named as such also where a package of
:data:`~brdfkit.errors.EXTRAS` is imported without :func:`~brdfkit.errors.require_extra`); 3
an internal error (a bug: please report it); 130 interrupted. Every error is one line
on standard error; user text is never read as Rich markup; set ``BRDFKIT_TRACEBACK=1`` to see the
traceback of an internal error.

The first Ctrl-C (SIGINT) or SIGTERM ends the command at once (:func:`stop_on_interrupt`): every
process it started is stopped, queued work is dropped, the program unwinds (so that temporary
files are removed), prints one ``interrupted`` line and exits with status 130; a second signal
changes nothing, and if the unwinding takes longer than :data:`UNWIND_DEADLINE_S` the process
ends itself.
"""

from __future__ import annotations

import importlib
import inspect
import os
import pkgutil
import signal
import sys
import threading
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import typer
from rich.console import Console
from rich.text import Text
from typer.core import TyperGroup

import brdfkit
from brdfkit.cli._plain_values import plain_values

BAD_INPUT = 2
"""Exit status for bad input (usage errors included, as click does)."""
CHECK_FAILED = 1
"""Exit status of a check that contradicts a claim."""
INTERNAL_ERROR = 3
"""Exit status of an unexpected failure: a bug in brdfkit."""
INTERRUPTED = 130
"""Exit status of a command ended by Ctrl-C or SIGTERM (128 + SIGINT, as shells report it)."""
UNWIND_DEADLINE_S = 2.0
"""Seconds an interrupted command may take to unwind before the process ends itself."""

console = Console(markup=False, highlight=False)
"""Results (tables, "wrote …" lines) on standard output; text is never read as markup."""
status = Console(stderr=True, markup=False, highlight=False)
"""Progress bars and errors on standard error, so that standard output holds only results."""


def progress(*columns: Any) -> Any:
    """A transient progress bar on stderr (``rich.progress.Progress`` with ``columns``), shown
    only on a terminal: a pipe or a log file gets neither the bar nor the blank line it leaves
    (:class:`_NoProgress`, which spares importing the bar's machinery, ~15 ms)."""
    if not status.is_terminal:
        return _NoProgress()
    from rich.progress import Progress

    return Progress(*columns, console=status, transient=True)


class _NoProgress:
    """The progress bar off a terminal: a context taking the bar's calls, showing nothing."""

    def __enter__(self) -> _NoProgress:
        return self

    def __exit__(self, *exception: object) -> None:
        return None

    def add_task(self, description: str, **fields: Any) -> int:
        return 0

    def update(self, task: int, **fields: Any) -> None:
        return None

    def refresh(self) -> None:
        return None


def shown(text: Any) -> str:
    """``text`` (a path or message) made printable: bytes that are not UTF-8 in a file name
    (carried by Python as lone surrogates) appear as ``\\xff`` escapes."""
    return str(text).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def _error_line(message: str, label: str = "error") -> None:
    if _interrupting:  # the failure is the interrupt's doing (a pool whose workers were stopped)
        _report_interrupted()
        return
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
            words = args[0] if args else kwargs.get("args")
            command = _command(sys.argv[1:] if words is None else list(words))
            code = _run(
                lambda: super(_Group, self).main(*args, standalone_mode=False, **kwargs), command
            )
        if standalone_mode and _interrupting:
            _exit_unwound()
        if standalone_mode:
            sys.exit(code)
        return code

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        plain_values(self.get_params(ctx))
        return super().parse_args(ctx, args)

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        """The subcommand ``cmd_name``; it converts its values without pydantic where they
        are plain (:func:`~brdfkit.cli._plain_values.plain_values`)."""
        command = super().get_command(ctx, cmd_name)
        if command is not None:
            plain_values(command.get_params(ctx))
        return command


def _exit_unwound() -> NoReturn:
    """End an interrupted command that has unwound (its ``finally`` blocks ran, its temporaries
    are gone) without the interpreter's exit handlers, which would wait for the threads of the
    abandoned work (a pool's manager, an import under way)."""
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    os._exit(INTERRUPTED)


def _run(call: Any, command: str) -> int:
    """Run the command line; return its exit status, having printed any error as one line."""
    code = _outcome(call, command)
    if _interrupting:  # whatever became of the Interrupted raised (a library may swallow it)
        _report_interrupted()
        return INTERRUPTED
    return code


_NOT_JSON = "Out of range float values are not JSON compliant"


def _reason(error: Exception) -> str:
    """The error line's text: the error's message, or what a result that holds NaN or
    infinity means (``json.dumps(..., allow_nan=False)`` refusing it names nothing)."""
    text = str(error) or type(error).__name__
    if text.startswith(_NOT_JSON):
        value = text.removeprefix(_NOT_JSON).strip(": ") or "NaN or infinity"
        return (
            f"the result holds {value}, which no output may: an input holds values the "
            "computation cannot use (NaN, infinity, or too large); nothing was written"
        )
    return text


def _command(words: list[str]) -> str:
    """The command that ``words`` (the arguments) run, in backquotes: "`brdfkit explore`"."""
    name = [str(word) for word in words if not str(word).startswith("-")][:1]
    return "`" + " ".join(["brdfkit", *name]) + "`"


def _outcome(call: Any, command: str) -> int:
    from brdfkit.errors import BrdfkitError, MissingExtraError, missing_extra

    try:
        code = call()
    except Interrupted:
        return INTERRUPTED  # reported by _run
    except typer.Abort as error:  # click's own answer to KeyboardInterrupt and EOF
        by_ctrl_c = isinstance(error.__context__, KeyboardInterrupt)
        _error_line("interrupted" if by_ctrl_c else "aborted")
        return INTERRUPTED
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
        return INTERRUPTED
    except MissingExtraError as error:
        _error_line(str(MissingExtraError(error.module, error.extra, command)))
        return BAD_INPUT
    except MemoryError:
        _error_line("out of memory: use a smaller size option (-r, --samples, --height, …)")
        return BAD_INPUT
    except (BrdfkitError, ValueError, OSError) as error:
        if os.environ.get("BRDFKIT_TRACEBACK"):
            raise
        _error_line(_reason(error))
        return BAD_INPUT
    except Exception as error:
        if os.environ.get("BRDFKIT_TRACEBACK"):
            raise
        missing = missing_extra(error) if isinstance(error, ModuleNotFoundError) else None
        if missing is not None:  # an optional package imported without require_extra
            _error_line(str(MissingExtraError(missing.module, missing.extra, command)))
            return BAD_INPUT
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


_COMMAND_MODULES = sorted(
    module.name
    for module in pkgutil.iter_modules([str(Path(__file__).parent)])
    if not module.name.startswith("_")
)
"""The modules of :mod:`brdfkit.cli` that each register a command on :data:`app`."""


def load_commands(words: Sequence[str] | None = None) -> None:
    """Register the commands on :data:`app` by importing their modules: where ``words`` (a
    command line's arguments) start with a command's name (``render``, ``solid-angle``),
    that command's module alone, else (and where that module registers no command of that
    name) every module. Importing a module again does nothing."""
    first = str(words[0]) if words else ""
    module = first.replace("-", "_")
    if module in _COMMAND_MODULES:
        importlib.import_module(f"brdfkit.cli.{module}")
    if first not in {command.name for command in app.registered_commands}:
        for name in _COMMAND_MODULES:
            importlib.import_module(f"brdfkit.cli.{name}")
    for command in app.registered_commands:
        if command.help is None and command.callback is not None:
            command.help = _reflowed(inspect.getdoc(command.callback) or "")


def _reflowed(doc: str) -> str:
    """A docstring with each paragraph on one line, for the help formatter to wrap to the
    terminal (it keeps single line breaks, which left hard-wrapped fragments)."""
    return "\n\n".join(" ".join(paragraph.split()) for paragraph in doc.split("\n\n"))


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


class Interrupted(BaseException):
    """Raised in the main thread by the first Ctrl-C or SIGTERM once :func:`stop_on_interrupt`
    is in force. A ``BaseException`` (as ``KeyboardInterrupt``) that click does not catch, so
    ``finally`` blocks run on the way out and no ``except Exception`` stops it."""


_command_pid: int | None = None
_interrupting = False
_interrupt_reported = threading.Lock()


def stop_on_interrupt() -> None:
    """Make the first SIGINT or SIGTERM end the command at once (see the module's docstring).

    The handler, in the command's own process: stops every process it started
    (:func:`stop_workers`), sets an alarm that ends the process after :data:`UNWIND_DEADLINE_S`
    whatever the unwinding waits for (a signal, not a thread: a forking command must stay
    single-threaded), and raises :class:`Interrupted`. A later signal is ignored. A worker
    forked by the command inherits the handler and exits at once, silently: the command's
    process owns the work and its temporaries.
    """
    global _command_pid
    _command_pid = os.getpid()
    signal.signal(signal.SIGINT, _on_interrupt)
    signal.signal(signal.SIGTERM, _on_interrupt)
    default_hook = sys.unraisablehook

    def quiet(unraisable: Any) -> None:  # raised where Python can only report it (a callback)
        if not isinstance(unraisable.exc_value, Interrupted):
            default_hook(unraisable)

    sys.unraisablehook = quiet


def _on_interrupt(signum: int, frame: Any) -> None:
    global _interrupting
    if os.getpid() != _command_pid:
        os._exit(INTERRUPTED)  # a forked worker: nothing of its own to clean up
    if _interrupting:
        return
    _interrupting = True
    signal.signal(signal.SIGALRM, _end_now)
    signal.setitimer(signal.ITIMER_REAL, UNWIND_DEADLINE_S)
    stop_workers()
    raise Interrupted


def _report_interrupted() -> None:
    """Print the ``interrupted`` line, once, whichever of the unwinding and the alarm is first."""
    if _interrupt_reported.acquire(blocking=False):
        os.write(sys.stderr.fileno(), b"error: interrupted\n")


def _end_now(signum: int, frame: Any) -> None:
    stop_workers()
    _report_interrupted()
    os._exit(INTERRUPTED)


def stop_workers() -> None:
    """Kill every process this one started, and theirs (a pool's workers, a local Dask
    cluster's nannies and workers): the work they hold is abandoned with the command.

    The descendants are listed by psutil where it is installed (it comes with the ``dask``
    extra), else the children :mod:`multiprocessing` started; SIGKILL, because a worker busy
    in compiled code would not run a Python handler for SIGTERM before it returned.
    """
    # multiprocessing is imported only by the commands that start workers: where it is not
    # imported, it started none (and no resource tracker)
    started = sys.modules.get("multiprocessing")
    try:
        import psutil
    except ImportError:
        pids = [] if started is None else [child.pid for child in started.active_children()]
    else:
        pids = [child.pid for child in psutil.Process().children(recursive=True)]
    # multiprocessing's resource tracker is no worker: killed, it would be started again on the
    # way out, and print a traceback for every semaphore then released
    tracking = sys.modules.get("multiprocessing.resource_tracker")
    tracker = getattr(getattr(tracking, "_resource_tracker", None), "_pid", None)
    for pid in set(pids) - {tracker}:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:  # it ended meanwhile
            pass
