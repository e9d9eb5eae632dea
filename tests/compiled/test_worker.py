"""A worker process compiles into the kernel cache and never outlives its command."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from brdfkit.compiled import cache as kernel_cache
from brdfkit.compiled import worker
from brdfkit.render import compiled_shading


@pytest.fixture(autouse=True)
def _workers_whatever_the_load(monkeypatch):
    monkeypatch.setenv(worker.ENV, "1")


def test_a_worker_runs_its_call_and_reports_success():
    with worker.start("time", "sleep", 0.0) as job:
        assert job.wait()
    with worker.start("math", "sqrt", -1.0) as job:  # raises in the worker
        assert not job.wait()


def test_the_tile_kernels_worker_compiles_without_the_packages_marked_absent():
    """numba's first compile checks for SciPy's BLAS: without SciPy it still compiles, and an
    import of a package marked absent fails in the worker."""
    code = textwrap.dedent(
        """
        import numba
        assert numba.njit(lambda x: x + 1)(1) == 2
        try:
            import scipy
        except ImportError:
            pass
        else:
            raise SystemExit(1)
        """
    )
    with worker.start("builtins", "exec", code, absent=compiled_shading._NOT_FOR_KERNELS) as job:
        assert job.wait()


def test_leaving_the_context_ends_a_running_worker():
    job = worker.start("time", "sleep", 60.0)
    with job:
        pass
    assert job._process.poll() is not None


def test_no_worker_without_a_cache(monkeypatch):
    monkeypatch.setenv(kernel_cache.ENV, "")
    assert worker.start("time", "sleep", 0.0) is None


def test_no_worker_where_the_load_leaves_no_core_free(monkeypatch):
    cores = len(os.sched_getaffinity(0))
    monkeypatch.delenv(worker.ENV)
    monkeypatch.setattr(os, "getloadavg", lambda: (cores + worker.BUSY_LOAD, 0.0, 0.0))
    assert worker.start("time", "sleep", 0.0) is None
    monkeypatch.setattr(os, "getloadavg", lambda: (cores + worker.BUSY_LOAD - 0.5, 0.0, 0.0))
    with worker.start("time", "sleep", 0.0) as job:
        assert job.wait()
    monkeypatch.setenv(worker.ENV, "0")
    assert worker.start("time", "sleep", 0.0) is None


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="reads /proc")
def test_a_worker_ends_when_the_process_that_started_it_is_gone(tmp_path):
    """The parent killed outright (no clean-up runs): its worker ends itself."""
    code = textwrap.dedent(
        """
        import os
        from brdfkit.compiled import worker
        job = worker.start("time", "sleep", 60.0)
        print(job._process.pid, flush=True)
        os._exit(0)
        """
    )
    env = {**os.environ, kernel_cache.ENV: str(tmp_path), worker.ENV: "1"}
    env["PYTHONPATH"] = str(Path(worker.__file__).parents[2])
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    pid = int(done.stdout.split()[0])
    deadline = time.monotonic() + 10
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(pid)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (not a zombie: an orphan is reaped by init)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"
