"""Ctrl-C and SIGTERM end a command at once: one ``interrupted`` line, exit 130, no worker
left, no temporary file, however many times the signal comes."""

from __future__ import annotations

import contextlib
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


@pytest.mark.slow
def test_sigterm_to_the_atlas_ends_it_and_its_workers(tmp_path):
    """SIGTERM ended the parent with a traceback ("Exception ignored in atexit callback …
    os.waitpid") and left its pool workers alive under PID 1."""
    process = _start(
        "atlas", "-o", str(tmp_path / "atlas"), "-m", "lambertian", "-m", "ggx(alpha=0.3)",
        "-r", "16", "-s", "1", "--no-checks",
    )  # fmt: skip
    _wait_for_workers(process)
    workers = psutil.Process(process.pid).children(recursive=True)
    process.send_signal(signal.SIGTERM)  # as `kill PID`: the parent alone
    _, stderr = process.communicate(timeout=5)
    assert (process.returncode, stderr) == (130, "error: interrupted\n")
    _, alive = psutil.wait_procs(workers, timeout=2)
    assert alive == []
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


# ------------------------------------------------------------------- from the first moment


def _console_script(folder: Path) -> Path:
    """The ``brdfkit`` script pip writes for ``[project.scripts]`` (its template), in
    ``folder``."""
    import tomllib

    pyproject = Path(_app.__file__).parents[3] / "pyproject.toml"
    module, function = tomllib.loads(pyproject.read_text())["project"]["scripts"]["brdfkit"].split(
        ":"
    )
    script = folder / "brdfkit"
    script.write_text(
        f"#!{sys.executable}\nimport re\nimport sys\nfrom {module} import {function}\n"
        "if __name__ == '__main__':\n"
        "    sys.argv[0] = re.sub(r'(-script\\.pyw|\\.exe)?$', '', sys.argv[0])\n"
        f"    sys.exit({function}())\n"
    )
    return script


def _run_script(script: Path, *args: str, **options) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(Path(_app.__file__).parents[2]))
    return subprocess.Popen(
        [sys.executable, *options.pop("flags", ()), str(script), *args],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, **options,
    )  # fmt: skip


def test_importing_brdfkit_costs_next_to_nothing():
    """The root package is all that runs before the command's Ctrl-C guard: no package
    metadata, no NumPy."""
    code = "import sys, brdfkit; print(sorted(set(sys.modules) & {'importlib.metadata', 'numpy'}))"
    env = dict(os.environ, PYTHONPATH=str(Path(_app.__file__).parents[2]))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert done.stdout.strip() == "[]", done.stderr


def test_a_ctrl_c_at_any_moment_of_the_start_prints_one_line(tmp_path):
    """A Ctrl-C in the first tens of ms of ``brdfkit`` could show Python's traceback. From the
    moment brdfkit's entry module is imported (``-X importtime`` reports it), a SIGINT 10, 30,
    60 or 100 ms later, in the imports or in the command, ends it with one line and 130."""
    script = _console_script(tmp_path)
    outcomes = {}

    def interrupt(delay: float) -> None:
        process = _run_script(script, "atlas", "--help", flags=("-X", "importtime"))
        for line in process.stderr:
            if line.rstrip().endswith("brdfkit.cli._entry"):
                break
        time.sleep(delay)
        process.send_signal(signal.SIGINT)
        _, rest = process.communicate(timeout=60)
        outcomes[delay] = (process.returncode, [
            line for line in rest.splitlines() if not line.startswith("import time:")
        ])  # fmt: skip

    threads = [threading.Thread(target=interrupt, args=(d,)) for d in (0.01, 0.03, 0.06, 0.1)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for delay, (status, lines) in outcomes.items():
        assert (status, lines) in ((130, ["error: interrupted"]), (0, [])), (delay, lines)
    assert any(status == 130 for status, _ in outcomes.values())


def test_a_worker_that_runs_the_script_again_takes_no_guard(monkeypatch):
    """A worker that multiprocessing spawns runs the console script again (as __mp_main__);
    with the guard, each printed an "interrupted" line of its own on a SIGTERM."""
    from brdfkit.cli import _entry

    monkeypatch.setattr(sys, "argv", ["/usr/bin/brdfkit", "fit"])
    monkeypatch.setattr(sys, "orig_argv", [sys.executable, "/usr/bin/brdfkit", "fit"])
    assert _entry.is_console_script()
    spawned = [sys.executable, "-c", "from multiprocessing.spawn import spawn_main; spawn_main()"]
    monkeypatch.setattr(sys, "orig_argv", [*spawned, "--multiprocessing-fork"])
    assert not _entry.is_console_script()
    monkeypatch.setattr(sys, "argv", ["-c"])
    monkeypatch.setattr(sys, "orig_argv", [sys.executable, "-c", "import brdfkit.cli"])
    assert not _entry.is_console_script()  # a library import


@pytest.mark.slow
def test_a_dask_batch_interrupted_while_its_workers_start_prints_one_line(tmp_path):
    """Two Ctrl-C while its Dask workers started: a batch printed their KeyboardInterrupt
    tracebacks (66 lines) and multiprocessing's warning of leaked semaphores."""
    pytest.importorskip("distributed", reason="needs the dask extra")
    out = tmp_path / "sets"
    process = _run_script(
        _console_script(tmp_path), "synth", "-s", "sphere:16", "-o", str(out), "--workers", "2",
        start_new_session=True,
    )  # fmt: skip
    _wait_for_workers(process)
    os.killpg(process.pid, signal.SIGINT)  # the workers are starting: importing their modules
    time.sleep(0.3)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=10)
    assert (process.returncode, stderr) == (130, "error: interrupted\n")
    time.sleep(0.3)
    assert _session_processes(process.pid) == []
    assert not [p for p in tmp_path.rglob(".brdfkit-*") if p.name != ".brdfkit-outputs.json"]


@pytest.mark.parametrize("signal_to", ["group", "parent"])
def test_an_interrupted_first_render_leaves_no_kernel_worker(tmp_path, signal_to):
    """The first render's kernel build starts a worker process (the tile kernel on another
    core); Ctrl-C (the group) or SIGTERM (the parent alone) ends both, with one line."""
    env = dict(os.environ, PYTHONPATH=str(Path(_app.__file__).parents[2]))
    env["BRDFKIT_CACHE_DIR"] = str(tmp_path / "kernels")  # empty: the kernels are built
    env["BRDFKIT_COMPILE_WORKER"] = "1"  # whatever the machine's load
    process = subprocess.Popen(
        [sys.executable, "-c", _COMMAND, "render", "-b", "ggx(alpha=0.3)", "-r", "16", "-s",
         "1", "-o", str(tmp_path / "x.png")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        env=env,
    )  # fmt: skip
    _wait_for_workers(process)
    workers = psutil.Process(process.pid).children(recursive=True)
    if signal_to == "group":
        os.killpg(process.pid, signal.SIGINT)
    else:
        process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=10)
    assert (process.returncode, stderr.splitlines()[-1:]) == (130, ["error: interrupted"])
    _, alive = psutil.wait_procs(workers, timeout=3)
    assert alive == []
    assert _session_processes(process.pid) == []
    assert not (tmp_path / "x.png").exists()
