"""The install as a user meets it: its size and how fast the command line starts.

In a fresh virtual environment, ``pip install`` of this tree with its default dependencies
(pip's cache may serve the downloads; nothing of the developer's environment is used), then:

- **Size**: the bytes of ``site-packages`` (every file, as ``du`` counts them, in MiB), and of
  each installed distribution (the files its ``RECORD`` lists, compiled ``.pyc`` included):
  the total, and the ten largest.
- **Without JAX**: the same after ``pip uninstall`` of jax, jaxlib and the two packages only
  they require (ml_dtypes, opt_einsum) in that environment (JAX serves only the tracer of
  :mod:`brdfkit.compiled`, which is to leave the default install).
- **Start-up**: wall and CPU seconds of fresh processes, interleaved over ``--repeats`` rounds:
  the console script's ``brdfkit --help``, ``python -c "import brdfkit"`` and, for scale,
  ``python -c pass``; the median and the minimum of each.

Run ``python benchmarks/bench_install.py`` (a few minutes, mostly pip); results go to
``benchmarks/results/install.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _machine import write_results

ROOT = Path(__file__).resolve().parents[1]
MIB = 2**20
JAX = ("jax", "jaxlib", "ml_dtypes", "opt_einsum")
"""JAX and the distributions that only it requires."""

_SIZES = """
import json, sys
from importlib import metadata
from pathlib import Path

sizes = {}
for dist in metadata.distributions():
    total = 0
    for name in dist.files or []:
        path = Path(dist.locate_file(name))
        if path.is_file():
            total += path.stat().st_size
    sizes[dist.metadata["Name"]] = total
json.dump(sizes, sys.stdout)
"""


def _run(command: list[str], **kwargs: Any) -> subprocess.CompletedProcess:
    return subprocess.run(command, check=True, capture_output=True, text=True, **kwargs)


def _folder_bytes(folder: Path) -> int:
    """Every file's size under ``folder`` (``du --apparent-size``)."""
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file() and not p.is_symlink())


def _sizes(python: Path, site_packages: Path) -> dict[str, Any]:
    distributions = json.loads(_run([str(python), "-c", _SIZES]).stdout)
    largest = sorted(distributions.items(), key=lambda item: -item[1])[:10]
    return {
        "site_packages_mib": round(_folder_bytes(site_packages) / MIB, 1),
        "distributions": len(distributions),
        "largest_mib": {name: round(size / MIB, 1) for name, size in largest},
    }


def _timed(command: list[str]) -> tuple[float, float]:
    """Wall and CPU (user + system) seconds of one run of ``command`` in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    _run(command, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _start_up(venv: Path, repeats: int) -> dict[str, Any]:
    python, brdfkit = venv / "bin" / "python", venv / "bin" / "brdfkit"
    commands = {
        "brdfkit --help": [str(brdfkit), "--help"],
        'python -c "import brdfkit"': [str(python), "-c", "import brdfkit"],
        'python -c "pass"': [str(python), "-c", "pass"],
    }
    for command in commands.values():  # warm the file cache
        _timed(command)
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
    for _ in range(repeats):
        for name, command in commands.items():
            runs[name].append(_timed(command))
    return {
        name: {
            "wall_median_s": round(statistics.median(w for w, _ in times), 3),
            "wall_min_s": round(min(w for w, _ in times), 3),
            "cpu_median_s": round(statistics.median(c for _, c in times), 3),
        }
        for name, times in runs.items()
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="rounds of start-up timings")
    parser.add_argument("--source", type=Path, default=ROOT, help="the tree to install")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="brdfkit-install-") as folder:
        venv = Path(folder) / "venv"
        _run([sys.executable, "-m", "venv", str(venv)])
        python = venv / "bin" / "python"
        env = {**os.environ, "PIP_DISABLE_PIP_VERSION_CHECK": "1"}
        env.pop("PYTHONPATH", None)
        start = time.perf_counter()
        _run([str(python), "-m", "pip", "install", "-q", str(args.source)], env=env)
        install_s = time.perf_counter() - start
        site_packages = Path(
            _run(
                [str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"]
            ).stdout.strip()
        )
        record: dict[str, Any] = {"pip_install_s": round(install_s, 1)}
        record["default"] = _sizes(python, site_packages)
        record["start_up"] = _start_up(venv, args.repeats)
        _run([str(python), "-m", "pip", "uninstall", "-q", "-y", *JAX], env=env)
        record["without_jax"] = _sizes(python, site_packages)
        record["load_average_during"] = [round(x, 2) for x in os.getloadavg()]
    path = write_results(__file__, record)
    print(json.dumps(record, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
