"""Ctrl-C and SIGTERM end a command at once: one ``interrupted`` line, exit 130, no worker
left, no temporary file, however many times the signal comes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from brdfkit.cli import _app

psutil = pytest.importorskip("psutil")

_COMMAND = "import sys; sys.argv[0] = 'brdfkit'; from brdfkit.cli import main; main()"


def _start(*args: str) -> subprocess.Popen:
    """``brdfkit ARGS`` in a session of its own (as a terminal's foreground job)."""
    env = dict(os.environ, PYTHONPATH=str(Path(_app.__file__).parents[2]))
    return subprocess.Popen(
        [sys.executable, "-c", _COMMAND, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=env,
    )


def _wait_for_workers(process: subprocess.Popen, timeout: float = 60.0) -> None:
    """Wait until ``process`` has started worker processes (its pool is busy)."""
    parent = psutil.Process(process.pid)
    deadline = time.monotonic() + timeout
    while not parent.children() and time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)
    if not parent.children():
        pytest.skip("the command started no worker process on this machine (one core)")


def _session_processes(session: int) -> list[int]:
    return [p.pid for p in psutil.process_iter() if _session(p) == session]


def _session(process) -> int | None:
    try:
        return os.getsid(process.pid) if process.status() != psutil.STATUS_ZOMBIE else None
    except (ProcessLookupError, psutil.Error):
        return None


def test_two_ctrl_c_end_the_atlas_and_its_workers_at_once(tmp_path):
    process = _start(
        "atlas", "-o", str(tmp_path / "atlas"), "-m", "lambertian", "-m", "ggx(alpha=0.3)",
        "-r", "16", "-s", "1", "--no-checks",
    )  # fmt: skip
    _wait_for_workers(process)
    os.killpg(process.pid, signal.SIGINT)  # as Ctrl-C: to the whole foreground group
    time.sleep(0.3)
    os.killpg(process.pid, signal.SIGINT)
    start = time.monotonic()
    try:
        _, stderr = process.communicate(timeout=5)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail("two Ctrl-C left the atlas running 5 s later")
    assert time.monotonic() - start < 5
    assert process.returncode == 130
    assert stderr == "error: interrupted\n"
    time.sleep(0.2)
    assert _session_processes(process.pid) == []
    assert not [p for p in tmp_path.rglob("*") if p.name.startswith(".brdfkit-")]


def test_stop_workers_kills_the_processes_the_command_started():
    import multiprocessing

    worker = multiprocessing.get_context("fork").Process(target=time.sleep, args=(60,))
    worker.start()
    _app.stop_workers()
    worker.join(5)
    assert worker.exitcode == -signal.SIGKILL


def _wait_for_import(process: subprocess.Popen, module: str, timeout: float = 30.0) -> None:
    """Wait until ``process`` has mapped ``module``'s compiled code (Linux's /proc)."""
    maps = Path(f"/proc/{process.pid}/maps")
    if not maps.exists():
        pytest.skip("needs /proc")
    deadline = time.monotonic() + timeout
    while module not in maps.read_text() and time.monotonic() < deadline:
        time.sleep(0.01)


def test_a_signal_while_starting_ends_the_command_quietly():
    process = _start("atlas", "--help")
    _wait_for_import(process, "numpy")  # brdfkit.cli's imports are under way
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=5)
    assert process.returncode in (0, 130)  # --help may have finished first
    assert "Traceback" not in stderr


def test_an_interrupt_drops_the_queued_kernel_tasks():
    from brdfkit.compiled.thread_pool import run_tasks

    done = []

    def task(item: int) -> None:
        if item > 20 and threading.current_thread() is threading.main_thread():
            raise KeyboardInterrupt
        time.sleep(0.01)
        done.append(item)

    with pytest.raises(KeyboardInterrupt):
        run_tasks(task, range(200), workers=2)
    time.sleep(0.05)
    assert len(done) < 40  # the helper stopped after the item in its hands, not 199 items


def test_stop_workers_spares_the_resource_tracker():
    """Killed, multiprocessing's tracker was started again on the way out of an interrupted
    Dask batch and printed a traceback per semaphore (49 lines after "interrupted")."""
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    tracker = resource_tracker._resource_tracker._pid
    _app.stop_workers()
    assert psutil.pid_exists(tracker) and psutil.Process(tracker).status() != psutil.STATUS_ZOMBIE
