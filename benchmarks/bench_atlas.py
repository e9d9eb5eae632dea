"""How long ``brdfkit atlas`` takes with its defaults, and how noisy its env-map spheres are.

Time: :func:`brdfkit.report.build_atlas` with the CLI's defaults (every model of
``DEFAULT_MODELS``, the bundled map, 96² spheres, 32 spp, checks on), ``--repeats`` times; the
minimum, the CPU seconds of the process and its workers (robust to other load) and the import
time are reported (the goal: under 15 s on 2 cores).

Noise: every sphere of every default card under the environment map, rendered as the atlas
renders it (:func:`~brdfkit.render.render_sphere`, default estimator) at the atlas's spp and at
16× that with another seed; the relative RMSE between the two inside the silhouette
(:func:`~brdfkit.mitsuba_scenes.relative_rmse`; the goal: every sphere under 1 %).
``--noise-resolution`` renders the noise check smaller (per-pixel noise does not depend on the
resolution; the default is the atlas's own).

    python benchmarks/bench_atlas.py [--repeats 1] [--noise-resolution 96] [--skip-noise]
        [--only CARD ...] [--json]

Results go to ``benchmarks/results/atlas.json`` and a summary on stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

RESOLUTION = 96
SAMPLES = 32
GOAL_SECONDS = 15.0
GOAL_NOISE = 0.01


def _cpu_seconds() -> float:
    """CPU seconds of this process and of its waited-for children (the atlas's forked
    workers): unlike wall time, hardly changed by other load on the machine."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def time_atlas(repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU seconds of each of ``repeats`` atlas builds."""
    from brdfkit.report import build_atlas

    seconds, cpu = [], []
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(repeats):
            start, start_cpu = time.perf_counter(), _cpu_seconds()
            build_atlas(Path(folder) / "index.html")
            seconds.append(time.perf_counter() - start)
            cpu.append(_cpu_seconds() - start_cpu)
    return seconds, cpu


def sphere_noise(resolution: int, only: list[str] | None = None) -> list[dict]:
    from brdfkit.data import default_envmap_path
    from brdfkit.lights import EnvironmentMap
    from brdfkit.mitsuba_scenes import interior_mask, relative_rmse
    from brdfkit.render import render_sphere
    from brdfkit.report import default_cards

    env = EnvironmentMap.from_file(default_envmap_path())
    mask = interior_mask(resolution)
    rows = []
    for title, models in default_cards():
        if only and title not in only:
            continue
        for k, model in enumerate(models):
            start = time.perf_counter()
            image = render_sphere(model, env, resolution, samples=SAMPLES, seed=1)
            seconds = time.perf_counter() - start
            reference = render_sphere(model, env, resolution, samples=16 * SAMPLES, seed=2)
            error = relative_rmse(image, reference, mask) if np.any(reference[mask]) else 0.0
            rows.append({"card": title, "example": k, "rel_rmse": error, "seconds": seconds})
            print(f"  {title} #{k + 1}: rel. RMSE {error:.4f} ({seconds:.2f} s)", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--noise-resolution", type=int, default=RESOLUTION)
    parser.add_argument("--skip-noise", action="store_true")
    parser.add_argument("--only", nargs="+", help="noise of these cards only (e.g. ggx)")
    parser.add_argument("--json", action="store_true", help="print the record as JSON")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results" / "atlas.json"))
    args = parser.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    start = time.perf_counter()
    import brdfkit.report  # noqa: F401

    import_seconds = time.perf_counter() - start
    record: dict = {
        "machine": f"{platform.machine()}, {len(os.sched_getaffinity(0))} cores usable, "
        f"{platform.python_version()}",
        "import_seconds": import_seconds,
    }
    if not args.skip_noise:
        print(f"noise at {SAMPLES} spp against {16 * SAMPLES} spp, {args.noise_resolution}²:")
        rows = sphere_noise(args.noise_resolution, args.only)
        record["noise"] = {"resolution": args.noise_resolution, "spheres": rows}
    seconds, cpu = time_atlas(args.repeats)
    record["atlas_seconds"] = seconds
    record["atlas_cpu_seconds"] = cpu
    if args.json:
        print(json.dumps(record, indent=2))
    else:
        best = min(seconds)
        verdict = "met" if best < GOAL_SECONDS else "NOT met"
        print(
            f"atlas: {best:.1f} s, {min(cpu):.1f} CPU s (import {import_seconds:.1f} s): "
            f"goal < {GOAL_SECONDS:g} s {verdict}"
        )
        if "noise" in record:
            rows = record["noise"]["spheres"]
            within = [r for r in rows if r["rel_rmse"] <= GOAL_NOISE]
            worst = max(rows, key=lambda r: r["rel_rmse"])
            print(
                f"spheres within {GOAL_NOISE:.0%} rel. RMSE of 16× spp: {len(within)}/{len(rows)}; "
                f"worst {worst['card']} #{worst['example'] + 1}: {worst['rel_rmse']:.4f}"
            )
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(record, indent=2) + "\n")


if __name__ == "__main__":
    main()
