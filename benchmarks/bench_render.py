"""Rendering efficiency of brdfkit against Mitsuba 3's ``direct`` integrator, side by side.

Scenes: :func:`brdfkit.interop.mitsuba.benchmark_scenes` (gold GGX under
``royal_esplanade_1k``, Lambertian + GGX plastic under ``studio_small_03_1k``, a MERL-layout
table of GGX copper), a unit sphere at 256², brdfkit's orthographic front view; Mitsuba gets
the same camera, the same map at its own texel nodes and the matching BSDF (see
:mod:`brdfkit.interop.mitsuba`).

Per scene and spp (16, 64), brdfkit's :func:`~brdfkit.render.render_sphere` (``compiled=True``:
the float32 kernel of :mod:`brdfkit.render.compiled_shading`, where the BRDF compiles; the NumPy
path where it does not, or with ``--numpy`` as well) and Mitsuba's ``mi.render`` alternate
``--repeats`` times with fresh seeds. Reported: seconds per image (the minimum; the kernels'
build time apart, "compile s"), the relative RMSE against the renderer's *own* reference at
``--reference`` spp (≥ 16× the largest spp; inside the silhouette,
:func:`~brdfkit.render.scene.interior_mask`; NumPy and compiled share one estimator and the
compiled reference), the efficiency 1/(seconds·error²) and its ratio to Mitsuba's (> 1:
brdfkit is more efficient), and how far the two references differ. Mitsuba's
llvm variant needs ``benchmarks/setup.sh``; without it the run falls back to ``scalar_rgb``
and says so.

    python benchmarks/bench_render.py [--data ../shared/data] [--repeats 3] [--reference 1024]
        [--only gold plastic] [--numpy] [--json]

Results go to ``benchmarks/results/render.json`` and a Markdown table on stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.interop import mitsuba as ms
from brdfkit.light import EnvironmentMap
from brdfkit.render import interior_mask, render_sphere
from brdfkit.render.compiled_shading import compiled_shader

RESOLUTION = 256
SPPS = (16, 64)
PAUSE = 0.05
"""Seconds of rest before each timed render: Dr.Jit's worker threads spin after a kernel and
would slow whatever runs next on a 2-core machine (see bench_brdf.py)."""


def timed(render: Callable[[], np.ndarray]) -> tuple[float, np.ndarray]:
    """``(seconds, image)`` of one call, after a short rest."""
    time.sleep(PAUSE)
    start = time.perf_counter()
    image = render()
    return time.perf_counter() - start, image


def bench_scene(mi: Any, scene: ms.Scene, env: EnvironmentMap, args: argparse.Namespace) -> list:
    """Interleaved timings and errors of the renderers on one scene."""
    mi_scene = ms.sphere_scene(mi, scene.mitsuba_bsdf, env, RESOLUTION)
    renderers: dict[str, Callable[[int, int], np.ndarray]] = {
        "mitsuba": lambda spp, seed: ms.render(mi, mi_scene, spp, seed),
    }
    compile_seconds = None
    plan = compiled_shader(scene.brdf, [env], method="auto")
    if plan is not None:  # where brdfkit.compiled or the table kernels compile the BRDF
        start = time.perf_counter()
        plan[0].build()
        compile_seconds = time.perf_counter() - start
        renderers["compiled"] = lambda spp, seed: render_sphere(
            scene.brdf, env, resolution=RESOLUTION, samples=spp, seed=seed, compiled=True
        )
    if args.numpy or plan is None:
        renderers["numpy"] = lambda spp, seed: render_sphere(
            scene.brdf, env, resolution=RESOLUTION, samples=spp, seed=seed, compiled=False
        )
    mask = interior_mask(RESOLUTION)
    for render in renderers.values():
        render(4, 12345)  # warm-up: Mitsuba's JIT, brdfkit's caches
    # each renderer's own reference; NumPy and compiled share one estimator (and the compiled
    # reference where there is one)
    references, reference_seconds = {}, {}
    for name in ("mitsuba", "compiled" if "compiled" in renderers else "numpy"):
        reference = timed(lambda r=renderers[name]: r(args.reference, 999))
        reference_seconds[name], references[name] = reference
    references.setdefault("numpy", references.get("compiled"))
    rows = []
    for spp in SPPS:
        seconds = {name: [] for name in renderers}
        errors = {name: [] for name in renderers}
        for repeat in range(args.repeats):
            for name, render in renderers.items():
                t, image = timed(lambda r=render, n=spp, s=1000 * spp + repeat: r(n, s))
                seconds[name].append(t)
                errors[name].append(ms.relative_rmse(image, references[name], mask))
        row: dict[str, Any] = {"scene": scene.name, "spp": spp}
        for name in renderers:
            t = min(seconds[name])
            error = float(np.sqrt(np.mean(np.square(errors[name]))))
            row[name] = {"seconds": t, "rel_rmse": error, "efficiency": 1 / (t * error**2)}
        for name in ("compiled", "numpy"):
            if name in row:
                ratio = row[name]["efficiency"] / row["mitsuba"]["efficiency"]
                row[f"{name}_efficiency_ratio"] = ratio
        row["compile_seconds"] = compile_seconds
        brdfkit = "compiled" if "compiled" in references else "numpy"
        row["reference_agreement"] = ms.relative_rmse(
            references[brdfkit], references["mitsuba"], mask
        )
        row["reference_seconds"] = reference_seconds
        rows.append(row)
    return rows


def _cell(row: dict, name: str) -> str:
    if name not in row:
        return " – | – | – |"
    r = row[name]
    ratio = row[f"{name}_efficiency_ratio"]
    return f" {r['seconds']:.3f} | {r['rel_rmse']:.4f} | {ratio:.2f} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BRDFKIT_DATA", "../shared/data"))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--reference", type=int, default=16 * max(SPPS))
    parser.add_argument("--only", nargs="*", help="scene names to run (default: all)")
    parser.add_argument("--numpy", action="store_true", help="also time the NumPy path")
    parser.add_argument("--json", action="store_true", help="print the record as JSON")
    parser.add_argument("--out", help="results file (default: benchmarks/results/render.json)")
    args = parser.parse_args()
    mi, variant = ms.load_mitsuba()
    if variant != "llvm_ad_rgb":
        print(f"Mitsuba's llvm_ad_rgb is unavailable (run benchmarks/setup.sh): using {variant}")
    rows = []
    if not args.json:
        print(
            "| scene | spp | Mitsuba s | Mitsuba rel. RMSE | compiled s | compiled rel. RMSE "
            "| efficiency compiled/Mitsuba | NumPy s | NumPy rel. RMSE "
            "| efficiency NumPy/Mitsuba | compile s | references differ |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for scene in ms.benchmark_scenes():
        if args.only and scene.name not in args.only:
            continue
        env = EnvironmentMap.from_file(Path(args.data) / "envmaps" / "polyhaven" / scene.envmap)
        for row in bench_scene(mi, scene, env, args):
            rows.append(row)
            m = row["mitsuba"]
            compile_s = row["compile_seconds"]
            if not args.json:
                print(
                    f"| {row['scene']} | {row['spp']} | {m['seconds']:.3f} | {m['rel_rmse']:.4f} |"
                    + _cell(row, "compiled")
                    + _cell(row, "numpy")
                    + (f" {compile_s:.1f} |" if compile_s is not None else " – |")
                    + f" {row['reference_agreement']:.4f} |",
                    flush=True,
                )
    record = {
        "resolution": RESOLUTION,
        "reference_spp": args.reference,
        "repeats": args.repeats,
        "mitsuba": f"{mi.__version__} {variant}",
        "host": f"{platform.machine()}, {os.cpu_count()} CPUs, {platform.python_version()}",
        "rows": rows,
    }
    if args.json:
        print(json.dumps(record, indent=2))
    else:
        worst = min(
            (
                r.get("compiled_efficiency_ratio") or r.get("numpy_efficiency_ratio"),
                r["scene"],
                r["spp"],
            )
            for r in rows
        )
        print(f"\nlowest efficiency brdfkit/Mitsuba: {worst[0]:.2f} ({worst[1]}, {worst[2]} spp)")
    from _machine import header, results_path

    out = Path(args.out) if args.out else results_path(__file__)
    out.parent.mkdir(parents=True, exist_ok=True)
    record = {**header(__file__, packages=("mitsuba", "drjit")), **record}
    out.write_text(json.dumps(record, indent=2) + "\n")


if __name__ == "__main__":
    main()
