"""Compiling kernels on another core: a worker process that fills the disk cache.

numba compiles on one core, holding the GIL, so threads of one process compile one kernel at a
time. A kernel that does not depend on the others (the render's tile kernel, which takes the
BRDF's kernels as arguments) can be compiled by a second process while this one compiles the
rest; the worker writes its machine code into :mod:`brdfkit.compiled.cache` (numba's atomic
writes: an entry is complete or absent) and this process loads it from there when it first
calls the kernel. Where the worker fails or is not there (the cache turned off), the kernel is
compiled in this process at that call, as without a worker: a worker only saves time.

:func:`start` runs ``module.function(*arguments)`` in a fresh Python (``python -c``, the same
brdfkit and cache folder, its output discarded); the returned :class:`Worker` is a context
manager that ends the process on the way out (an interrupt, an error, or a caller that no
longer waits), so that no process outlives the command; workers still running when the
interpreter exits (started from a thread the exit does not wait for) are ended then. The
worker also ends itself when its parent is gone (checked every :data:`PARENT_POLL` seconds:
a parent killed outright runs no clean-up).
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import TracebackType
from typing import Any

from brdfkit.compiled import cache as kernel_cache

PARENT_POLL = 0.25
"""Seconds between a worker's checks that the process that started it still runs."""

ENV = "BRDFKIT_COMPILE_WORKER"
"""Environment variable: ``1`` starts workers whatever the load, ``0`` never; unset, by the
load (:data:`BUSY_LOAD`)."""

BUSY_LOAD = 1.0
"""Load average above this process's cores at which :func:`start` starts no worker: the
machine's other work already takes every core, and a second process would share them with
this one, adding its own start (a Python and numba, ~1 s of CPU) to the total. Measured with
the first render of ``brdfkit render`` on 2 cores, paired with one process compiling
everything: with a worker 0.72–0.92× its time at load averages 1.6–2.6, 0.9–1.3× at 3.5–6.0."""


class Worker:
    """A worker process (:func:`start`); ``with`` ends it on the way out."""

    def __init__(self, process: subprocess.Popen) -> None:
        self._process = process
        with _LOCK:
            if not _RUNNING:
                atexit.register(_stop_running)
            _RUNNING.add(self)

    def wait(self) -> bool:
        """Wait for the worker to finish; whether it succeeded (its kernels are on disk)."""
        return self._process.wait() == 0

    def stop(self) -> None:
        """End the worker if it still runs (SIGTERM), and reap it."""
        if self._process.poll() is None:
            self._process.terminate()
        self._process.wait()
        with _LOCK:
            _RUNNING.discard(self)

    def __enter__(self) -> Worker:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.stop()


_RUNNING: set[Worker] = set()
_LOCK = threading.Lock()


def _stop_running() -> None:
    """End the workers still running (at the interpreter's exit)."""
    with _LOCK:
        running = list(_RUNNING)
    for worker in running:
        worker.stop()


def start(
    module: str, function: str, *arguments: Any, absent: tuple[str, ...] = ()
) -> Worker | None:
    """Start a process calling ``module.function(*arguments)`` (Python literals) with this
    process's brdfkit and kernel cache folder, the top-level packages ``absent`` marked as
    not installed there (an import of one raises :class:`ImportError`: for optional packages
    the call does not need but its imports would load); ``None`` (nothing started) where the
    cache is off or cannot be written, the machine is busy (:data:`BUSY_LOAD`) or the process
    cannot be started."""
    folder = kernel_cache.root()
    if folder is None or kernel_cache.directory() is None or _busy():
        return None
    source = str(Path(__file__).parents[2])  # the folder holding this brdfkit package
    path = os.environ.get("PYTHONPATH")
    environment = {
        **os.environ,
        kernel_cache.ENV: str(folder),
        "PYTHONPATH": source if not path else f"{source}{os.pathsep}{path}",
    }
    call = f"{function}(*{arguments!r})"
    statement = (
        f"import sys; sys.modules.update(dict.fromkeys({absent!r})); "
        f"from brdfkit.compiled.worker import serve; serve({os.getpid()}); "
        f"from {module} import {function}; {call}"
    )
    try:
        process = subprocess.Popen(
            [sys.executable, "-c", statement],
            env=environment,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except OSError:
        return None
    return Worker(process)


def _busy() -> bool:
    """Whether the load average leaves no core free for a worker (:data:`BUSY_LOAD`), or
    :data:`ENV` says so."""
    choice = os.environ.get(ENV, "")
    if choice in ("0", "1"):
        return choice == "0"
    try:
        load = os.getloadavg()[0]
    except OSError:  # no load average on this system: assume a free core
        return False
    return load >= len(os.sched_getaffinity(0)) + BUSY_LOAD


def serve(parent: int) -> None:
    """In a worker: end this process as soon as ``parent`` is no longer its parent (the
    process that started it has ended), from a daemon thread."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL)
        os._exit(1)

    threading.Thread(target=watch, name="brdfkit-worker-parent", daemon=True).start()


__all__ = ["BUSY_LOAD", "ENV", "PARENT_POLL", "Worker", "serve", "start"]
