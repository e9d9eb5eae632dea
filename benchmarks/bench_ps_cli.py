"""``brdfkit ps`` as a user meets it: a fresh process on a DiLiGenT folder, each default.

For each object (``--objects``, default bear and cat; ``sphere``, a ball of DiLiGenT's size,
stands in for its ball) the real DiLiGenT ground-truth normals
and depth of ``../shared/data/normal_integration/diligent`` are rendered under 96
DiLiGenT-like lights with cast shadows and noise (``bench_ps_materials.render``: a Lambertian
base and a GGX lobe of roughness 0.1) at full resolution, and written as a DiLiGenT folder
(16-bit PNGs, ``light_directions.txt``, ``light_intensities.txt``, ``mask.png``,
``Normal_gt.mat``). Then ``brdfkit ps FOLDER --json`` runs as a fresh process with its
defaults, with the previous defaults (``-m sparse_regression --integration least_squares``),
with ``-m inverse_rendering`` and with ``--uncalibrated``; each after one untimed run that
fills the kernel cache and Python's bytecode cache (an installed package has both). Before
them, on the first object, the defaults with every cache empty (numba's, brdfkit's and
Python's bytecode): a user's first run after installing, which compiles the kernels. Recorded:
wall and CPU seconds of the process (reading the 96 images included), and the measures it
prints: the normals' mean angular error, the depth's RMSE against the depth of the true
normals (% of range), the estimated lights' median error. About five minutes on 2 cores.

    python benchmarks/bench_ps_cli.py [--data ../shared/data] [--objects bear cat]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_ps_materials import material_brdf, render, shadowed_object
from brdfkit.vision import datasets

MATERIAL = "ggx 0.1"
"""The material of the renders (:data:`bench_ps_materials.ANALYTIC`)."""

RUNS = {
    "defaults": [],
    "previous defaults": ["-m", "sparse_regression", "--integration", "least_squares"],
    "inverse_rendering": ["-m", "inverse_rendering"],
    "uncalibrated": ["--uncalibrated"],
}
"""The options of each timed command."""


def write_folder(data_dir: Path, name: str, out: Path) -> Path:
    """A DiLiGenT folder of ``name`` rendered under :data:`MATERIAL`."""
    lights = datasets.diligent_like_lights()
    o = shadowed_object(data_dir, name, 1, lights)
    rng = np.random.default_rng(0)
    data = render(material_brdf(data_dir, MATERIAL), o.normals, o.mask, lights, o.lit, 0.005, rng)
    data.images[:] = np.clip(data.images / data.images.max(), 0.0, 1.0)  # 16-bit range
    folder = out / f"{name}PNG"
    datasets.save_diligent(data, folder)
    return folder


def timed(command: list[str], env: dict[str, str]) -> tuple[dict, float, float]:
    """The JSON the command prints, its wall and CPU seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return json.loads(done.stdout), wall, cpu


def main() -> None:
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--objects", nargs="+", default=["bear", "cat"])
    args = parser.parse_args()
    brdfkit = [shutil.which("brdfkit") or sys.exit("the brdfkit command is not installed")]
    records = []
    with tempfile.TemporaryDirectory(prefix="bench_ps_cli_") as scratch:
        work = Path(scratch)
        env = {**os.environ, "BRDFKIT_CACHE_DIR": str(work / "cache"),
               "PYTHONPYCACHEPREFIX": str(work / "pycache")}  # fmt: skip
        empty = {**env, "NUMBA_CACHE_DIR": str(work / "empty" / "numba"),
                 "BRDFKIT_CACHE_DIR": str(work / "empty" / "cache"),
                 "PYTHONPYCACHEPREFIX": str(work / "empty" / "pycache")}  # fmt: skip
        for name in args.objects:
            folder = write_folder(args.data, name, work)
            runs = [(run, options, env) for run, options in RUNS.items()]
            if name == args.objects[0]:
                runs.insert(0, ("defaults, empty caches", RUNS["defaults"], empty))
            for run, options, run_env in runs:
                command = [*brdfkit, "ps", str(folder), "--json", *options]
                if run_env is env:  # caches filled, not timed
                    timed([*command, "-o", str(work / "warm")], env)
                summary, wall, cpu = timed([*command, "-o", str(work / run)], run_env)
                record = {
                    "object": name, "run": run, "options": options,
                    "method": summary["method"], "integration": summary["integration"],
                    "wall_seconds": wall, "cpu_seconds": cpu,
                    "angular_error_deg": summary["angular_error_deg"]["mean"],
                    "depth_relative_rmse": summary["depth_relative_rmse"],
                    "light_error_deg": summary.get("light_error_deg", {}).get("median"),
                }  # fmt: skip
                print(json.dumps(record), flush=True)
                records.append(record)
    from _machine import write_results

    write_results(__file__, {"material": MATERIAL, "objects": args.objects, "records": records})


if __name__ == "__main__":
    main()
