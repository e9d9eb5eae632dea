"""The one results file of each benchmark, and the record of the machine it ran on.

Every ``bench_NAME.py`` writes its numbers to ``benchmarks/results/NAME.json`` through
:func:`write_results`, which adds

- ``benchmark``: ``NAME``;
- ``command``: the command line that made the file;
- ``machine``: :func:`machine`, the CPU model, core count, operating system, Python, the versions
  of the packages that matter to the numbers, the commit of the brdfkit that ran, the date and
  the load average.

``python benchmarks/tables.py`` turns these files into the tables of ``benchmarks/README.md``.
"""

from __future__ import annotations

import datetime
import importlib.util
import json
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"
"""``benchmarks/results``: one file per benchmark script, nothing else."""

PACKAGES = ("brdfkit", "numpy", "scipy", "numba", "llvmlite")
"""Packages whose versions every machine record lists; a benchmark adds its own (its peer)."""


def results_path(script: str | Path) -> Path:
    """``benchmarks/results/NAME.json`` for ``benchmarks/bench_NAME.py``."""
    return RESULTS / f"{Path(script).stem.removeprefix('bench_')}.json"


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else :func:`platform.processor`), or
    ``"unknown"``."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _commit() -> str:
    """The commit of the checkout brdfkit is imported from (``git rev-parse``), with ``+`` when
    it has uncommitted changes, or ``"unknown"`` (not a git checkout)."""
    spec = importlib.util.find_spec("brdfkit")  # finds the package without importing it
    if spec is not None and spec.origin is not None:
        root = Path(spec.origin).resolve().parent
    else:
        root = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short=12", "HEAD"],
            cwd=root, capture_output=True, text=True, check=True, timeout=10,
        ).stdout.strip()  # fmt: skip
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root, capture_output=True, text=True, check=True, timeout=10,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head + ("+" if dirty else "")


def machine(packages: Iterable[str] = ()) -> dict[str, Any]:
    """What the numbers of a run depend on besides the code: CPU, cores, OS, Python, package
    versions (:data:`PACKAGES` and ``packages``; ``"not installed"`` where absent), the commit of
    the brdfkit that is imported, the date (UTC) and the load average (1, 5, 15 minutes) when
    called: at the end of the run, when the results are written."""
    versions = {}
    for name in dict.fromkeys((*PACKAGES, *packages)):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or "unknown"
    return {
        "cpu": cpu_model(),
        "cores": cores,
        "os": platform.platform(),
        "python": platform.python_version(),
        "packages": versions,
        "commit": _commit(),
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }


def command() -> str:
    """This process's command line, as one would type it from the repository's root."""
    script = Path(sys.argv[0]).resolve()
    root = Path(__file__).resolve().parents[1]
    try:
        script = script.relative_to(root)
    except ValueError:
        pass
    return shlex.join(["python", str(script), *sys.argv[1:]])


def header(script: str | Path, packages: Iterable[str] = ()) -> dict[str, Any]:
    """The keys a results file starts with: ``benchmark``, ``command`` and ``machine``."""
    name = Path(script).stem.removeprefix("bench_")
    return {"benchmark": name, "command": command(), "machine": machine(packages)}


def write_results(
    script: str | Path,
    record: dict[str, Any],
    out: str | Path | None = None,
    packages: Iterable[str] = (),
) -> Path:
    """Write :func:`header` and ``record`` to ``out`` (default: :func:`results_path` of
    ``script``), atomically (a temporary file beside it, then renamed); return the path."""
    path = Path(out) if out is not None else results_path(script)
    full = {**header(script, packages), **record}
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_text(json.dumps(full, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    os.replace(temporary, path)
    return path
