"""The ``brdfkit`` console script's entry point: a Ctrl-C is answered from the first moment.

A command spends its first second or so importing (typer, NumPy, its modules); a Ctrl-C or
SIGTERM then would end it in a ``KeyboardInterrupt`` traceback. :func:`guard_the_start` is the
first thing :mod:`brdfkit.cli` runs (the console script's import reaches it before any other
module of brdfkit's but the root package's): from then on either signal prints the one
``error: interrupted`` line and exits with status 130, as a command does once it runs. Then
:func:`main` puts the command's own handling in place
(:func:`brdfkit.cli._app.stop_on_interrupt`: workers stopped, temporaries removed).

When the command has ended, :func:`main` freezes the garbage collector's objects
(:func:`gc.freeze`): the interpreter's exit then does not search the ~90,000 objects a render
leaves (modules, numba's types) for reference cycles, several times over (~0.1 s). Objects
are still released as their counts drop, ``atexit`` handlers run (the compile worker is
ended), and every output was written and closed before.

A command's set-up (its imports, numba's among them, and its kernels loaded) makes some
hundreds of thousands of objects that live as long as the process, and little garbage; the
collector, run every 700 allocations, would traverse them again and again (50–100 ms of a
render's start-up). :func:`start_up` pauses it for that set-up and, in the command's own
process, freezes what the set-up made (later collections leave those objects alone) before
it resumes. :func:`main` also has :func:`brdfkit.cli._app.load_commands` import the module
of the command it runs alone.

This module imports nothing but :mod:`collections.abc`, :mod:`contextlib`, :mod:`gc`,
:mod:`os`, :mod:`signal` and :mod:`sys`.
"""

from __future__ import annotations

import contextlib
import gc
import os
import signal
import sys
from collections.abc import Iterator

INTERRUPTED = 130
"""Exit status of a command ended by Ctrl-C or SIGTERM (128 + SIGINT, as shells report it)."""


def is_console_script() -> bool:
    """Whether this process runs the ``brdfkit`` command: not a library import, and not a
    worker process that multiprocessing's *spawn* started for the command.

    Such a worker runs the console script again (as ``__mp_main__``, with the command's
    ``sys.argv``) but has the command's process to end it: it must not answer a signal with
    an ``interrupted`` line of its own. Its interpreter was started with
    ``--multiprocessing-fork`` (:data:`sys.orig_argv`).
    """
    return (
        os.path.basename(sys.argv[0]) == "brdfkit" and "--multiprocessing-fork" not in sys.orig_argv
    )


def _interrupted_while_starting(signum: int, frame: object) -> None:
    """Ctrl-C or SIGTERM before the command has started: nothing to clean up yet."""
    os.write(2, b"error: interrupted\n")
    os._exit(INTERRUPTED)


def guard_the_start() -> None:
    """In the ``brdfkit`` command's own process (:func:`is_console_script`), make SIGINT and
    SIGTERM print ``error: interrupted`` and exit with status 130 until :func:`main` replaces
    the handler; elsewhere, do nothing."""
    if is_console_script():
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, _interrupted_while_starting)


_OWN_PROCESS: list[bool] = []
"""Holds ``True`` once :func:`main` runs: the process is the command's own (not a library's
caller, nor a test calling the application)."""


@contextlib.contextmanager
def start_up() -> Iterator[None]:
    """Run a command's set-up (imports, kernels loaded, scene built) with the cyclic garbage
    collector paused; then, in the command's own process (:func:`main`), freeze the objects
    that exist (:func:`gc.freeze`), and resume the collector (where it was running).

    Elsewhere (a test calling the application in its own process) nothing is frozen: the
    objects made meanwhile are collected as usual once the collector resumes."""
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        if _OWN_PROCESS:
            gc.freeze()
        gc.enable()


def main() -> None:
    """Entry point of the ``brdfkit`` console script (``[project.scripts]``)."""
    _OWN_PROCESS.append(True)
    from brdfkit.cli._app import (
        Interrupted,
        _exit_unwound,
        _report_interrupted,
        app,
        load_commands,
        stop_on_interrupt,
    )

    stop_on_interrupt()
    try:
        load_commands(sys.argv[1:])
        app()
    except Interrupted:  # while typer builds the commands, before the group's handling
        _report_interrupted()
        _exit_unwound()
    finally:  # the process ends: nothing left to collect but at its exit, which this spares
        gc.freeze()


__all__ = ["INTERRUPTED", "guard_the_start", "is_console_script", "main", "start_up"]
