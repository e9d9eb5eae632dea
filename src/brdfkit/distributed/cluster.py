"""The Dask client every distributed command runs on: local worker processes or a cluster.

References
----------
.. [1] Dask.distributed documentation, "LocalCluster" and "Client"
   (https://distributed.dask.org).
.. [2] CPython, ``Lib/multiprocessing/resource_tracker.py``,
   ``ResourceTracker.ensure_running``: the tracker is started behind a mask that blocks
   SIGINT and SIGTERM (bpo-33613).
"""

from __future__ import annotations

import logging
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from brdfkit.errors import ParameterError, require_extra

CONNECT_TIMEOUT = 10.0
"""Seconds to wait for a scheduler given by address before giving up."""

WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
"""Dask settings for brdfkit's local worker processes.

Dask exports ``MALLOC_TRIM_THRESHOLD_=65536`` to every worker so that freed memory returns to the
system quickly. Setting it switches off glibc's adaptive mmap threshold: then every large
temporary array is a fresh ``mmap``, zeroed page by page on first touch. A brdfkit fit allocates
many such arrays, so its page faults and system time multiply, and two workers faulting at once
slow each other. brdfkit's workers keep glibc's default (a variable the user exports still
applies).
"""

KEEP_MEMORY_CONFIG = {
    "distributed.nanny.pre-spawn-environ.MALLOC_MMAP_THRESHOLD_": 2**30,
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": 2**32,
}
"""Dask settings for workers that run many tasks of the same size (``keep_memory``, used by
batch fitting): glibc serves every array under 1 GiB from its heap and returns none of it to
the system under 4 GiB free, so each task reuses the pages the last one faulted in. With
glibc's default, arrays over its adaptive threshold (at most 32 MB: a MERL file's 35 MB of
values always) are still fresh ``mmap`` pages, whose faults cost system time, and faults of two
workers slow each other; with these settings a fit of a MERL table faults hardly at all. A
worker keeps its peak memory (a few hundred MB for a fit) until it exits; unfit for a worker
under a tight ``memory_limit``, whose resident size must fall when a task ends. A variable the
user exports still applies.
"""


def require_dask() -> None:
    """Raise a one-line error naming the extra when dask.distributed is not installed.

    Raises
    ------
    brdfkit.errors.MissingExtraError
        ``dask.array`` or ``dask.distributed`` cannot be imported.
    """
    require_extra("dask.array", "dask")
    require_extra("distributed", "dask")


@contextmanager
def client(
    workers: int | None = None,
    scheduler: str | None = None,
    *,
    memory_limit: str | int | None = None,
    keep_memory: bool = False,
) -> Iterator[Any]:
    """A :class:`dask.distributed.Client`, closed on exit.

    Parameters
    ----------
    workers : worker processes of a local cluster (one thread each, so that each task has a
        core; NumPy's BLAS gets one thread per worker from Dask's defaults). The machine's core
        count when omitted.
    scheduler : the address of a running scheduler (``tcp://host:8786``); then ``workers`` and
        ``memory_limit`` are the cluster's business and must be omitted. When omitted (and
        ``workers`` too), Dask's own setting ``scheduler-address`` (the environment variable
        ``DASK_SCHEDULER_ADDRESS``) is used if set.
    memory_limit : per-worker memory limit of the local cluster (bytes or ``"2GiB"``); Dask's
        ``"auto"`` (the machine's memory shared among the workers) when omitted.
    keep_memory : the local cluster's workers keep freed memory for their next task
        (:data:`KEEP_MEMORY_CONFIG`).

    Raises
    ------
    brdfkit.errors.ParameterError
        Both ``workers`` and ``scheduler``, a worker count below 1, or a scheduler that cannot
        be reached within :data:`CONNECT_TIMEOUT` seconds.
    """
    require_dask()
    import dask

    from distributed import Client

    if scheduler is None and workers is None and memory_limit is None:
        scheduler = dask.config.get("scheduler-address", None)
    if scheduler is not None:
        if workers is not None or memory_limit is not None:
            raise ParameterError(
                f"--workers and the memory limit belong to a local cluster; with --scheduler "
                f"{scheduler!r} the cluster sets them"
            )
        try:
            remote = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as error:
            raise ParameterError(
                f"--scheduler {scheduler!r}: cannot reach a Dask scheduler there ({error})"
            ) from None
        with remote:
            yield remote
        return
    if workers is not None and workers < 1:
        raise ParameterError(f"--workers must be at least 1; got {workers}")
    with local_cluster(workers, memory_limit, keep_memory) as cluster, Client(cluster) as local:
        yield local


def local_cluster(
    workers: int | None = None,
    memory_limit: str | int | None = None,
    keep_memory: bool = False,
) -> Any:
    """A :class:`dask.distributed.LocalCluster` of ``workers`` single-threaded processes
    (the core count when omitted) with :data:`WORKER_CONFIG`, no dashboard and quiet logs.

    ``memory_limit`` is per worker (Dask's ``"auto"`` when omitted); ``keep_memory``: the
    workers keep freed memory for their next task (:data:`KEEP_MEMORY_CONFIG`). The workers
    take no Ctrl-C (:func:`started_deaf_to_ctrl_c`): the process that started them ends them,
    and multiprocessing's resource tracker does not warn of the semaphores it then removes
    (:func:`quiet_resource_tracker`).
    """
    require_dask()
    import os

    import dask

    from distributed import LocalCluster

    config = dict(WORKER_CONFIG)
    if keep_memory:  # a variable the user exports still applies
        config.update(
            (key, value)
            for key, value in KEEP_MEMORY_CONFIG.items()
            if key.rsplit(".", 1)[1] not in os.environ
        )
    quiet_resource_tracker()
    with dask.config.set(config):  # read when each nanny is made
        return started_deaf_to_ctrl_c(
            lambda: LocalCluster(
                n_workers=workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                memory_limit=memory_limit if memory_limit is not None else "auto",
                dashboard_address=None,
                silence_logs=logging.CRITICAL,
            )
        )


_Made = TypeVar("_Made")


def started_deaf_to_ctrl_c(make: Callable[[], _Made]) -> _Made:
    """``make()``, run in a thread that blocks SIGINT, so that every thread it starts (Dask's
    event loop, the threads that start worker processes) and every process those start (the
    workers, whose blocked signals are inherited through ``fork`` and ``exec``) take no Ctrl-C.

    A terminal sends Ctrl-C to its whole foreground process group: a worker still importing
    its modules would die of it printing a ``KeyboardInterrupt`` traceback, while the command
    that owns the workers ends them itself (``brdfkit``'s commands kill every process they
    started at the first Ctrl-C). The calling thread keeps taking the signal, so an interrupt
    while the workers start ends the wait at once (the start then carries on unobserved until
    the process ends). Where threads have no signal masks (Windows), ``make()`` runs here.
    CPython starts its resource tracker behind the same mask, for the same race
    (bpo-33613 [1]_).

    References
    ----------
    .. [1] CPython issue bpo-33613, https://bugs.python.org/issue33613 (why
       ``multiprocessing.resource_tracker`` starts its process with SIGINT blocked).
    """
    if not hasattr(signal, "pthread_sigmask"):
        return make()
    outcome: dict[str, Any] = {}

    def run() -> None:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            outcome["made"] = make()
        except BaseException as error:  # handed to the caller below
            outcome["error"] = error

    thread = threading.Thread(target=run, name="brdfkit: start deaf to Ctrl-C", daemon=True)
    thread.start()
    thread.join()  # interruptible: the signal is the calling thread's
    if "error" in outcome:
        raise outcome["error"]
    return outcome["made"]


def quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker, if it is not running yet, with its warnings
    off.

    The tracker removes the named semaphores that a process left behind when it ended, and
    warns of each ("There appear to be 9 leaked semaphore objects to clean up at shutdown"):
    after an interrupt, the command ends without closing its cluster, and the removal is the
    intended clean-up, not a leak to report. The tracker gets the warning options of the
    interpreter that starts it (``sys.warnoptions``), so they are set for that start only.
    """
    from multiprocessing import resource_tracker

    quiet = "ignore::UserWarning"
    sys.warnoptions.append(quiet)
    try:
        resource_tracker.ensure_running()
    finally:
        sys.warnoptions.remove(quiet)


def completed(
    dask_client: Any,
    function: Callable[..., Any],
    arguments: dict[str, tuple],
    *,
    prefix: str,
) -> Iterable[tuple[str, Any]]:
    """Submit ``function(*arguments[key])`` for every key; yield ``(key, result)`` as the
    scheduler reports each task finished, each key exactly once.

    Keys name the tasks (``prefix-key``), so a task that Dask runs again after its worker died
    still yields one result. A task's exception is raised here when its result is reached.
    """
    from distributed import as_completed

    futures = {
        dask_client.submit(function, *args, key=f"{prefix}-{key}", pure=False, retries=0): key
        for key, args in arguments.items()
    }
    for future, result in as_completed(futures, with_results=True):
        yield futures[future], result
