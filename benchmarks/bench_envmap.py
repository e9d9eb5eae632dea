"""The first image under an environment map, and maps with a sun: brdfkit against Mitsuba 3.

The gold GGX sphere (``ggx(alpha=0.3, material='Au')``; Mitsuba gets the exporter's nearest
``roughconductor``, whose masking is separable) at 256² and 16 spp, brdfkit's orthographic
front view, under six Poly Haven maps: two with a small, very bright sun (``quarry_01``,
``royal_esplanade``), a moon (``moonless_golf``), a low sun (``spruit_sunrise``), a sunset
(``venice_sunset``) and an interior (``st_fagans_interior``). Per map, in one process and
interleaved, ``--repeats`` times with fresh seeds:

- **kept**: the scene kept between images (brdfkit's map and kernels, Mitsuba's loaded
  scene), one ``render`` each;
- **new**: a new scene per image, as a command or script makes one: brdfkit reads the map
  (:meth:`~brdfkit.light.EnvironmentMap.from_file`) and renders it with its tables
  forgotten first, in the process (:func:`~brdfkit.light.environment.clear_table_cache`)
  and on disk (an empty table store of its own, ``$BRDFKIT_CACHE_DIR`` pointing at a new
  temporary folder for that render: the lookups miss and the tables are stored, as for a
  map never seen on the machine; the time includes waiting for their disk copies, which
  brdfkit writes in the background); Mitsuba loads its scene (the ``envmap`` plugin reads
  the same file) and renders it;
- **again**: brdfkit's new scene of a map read before in the process (its tables found by
  content).

Kernels are built before the timings (compilation is measured elsewhere). The error is the
relative RMSE inside the silhouette against each renderer's own reference at
``--reference`` spp; the efficiency 1/(seconds·error²) (seconds: the best of the repeats;
error: the RMS over them), and brdfkit's efficiency over Mitsuba's per mode.

    python benchmarks/bench_envmap.py [--data ../shared/data] [--repeats 3] [--reference 1024]
        [--only quarry_01 royal_esplanade]

Results go to ``benchmarks/results/envmap.json`` and a Markdown table on stdout.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf import parse
from brdfkit.compiled import cache as kernel_cache
from brdfkit.interop import mitsuba as ms
from brdfkit.interop.mitsuba_export import to_mitsuba_dict
from brdfkit.light import EnvironmentMap
from brdfkit.light.environment import clear_table_cache, wait_for_table_store
from brdfkit.render import interior_mask, render_sphere
from brdfkit.render.compiled_shading import compiled_shader

MODEL = "ggx(alpha=0.3, material='Au')"
MAPS = (
    "quarry_01",
    "royal_esplanade",
    "moonless_golf",
    "spruit_sunrise",
    "venice_sunset",
    "st_fagans_interior",
)
RESOLUTION = 256
SPP = 16
PAUSE = 0.05
"""Seconds of rest before each timed render: Dr.Jit's worker threads spin after a kernel and
would slow whatever runs next on a 2-core machine (see bench_brdf.py)."""


def timed(render: Callable[[], np.ndarray]) -> tuple[float, np.ndarray]:
    """``(seconds, image)`` of one call, after a short rest."""
    time.sleep(PAUSE)
    start = time.perf_counter()
    image = render()
    return time.perf_counter() - start, image


@contextlib.contextmanager
def forgotten_tables(check: bool = True) -> Iterator[None]:
    """The maps' tables forgotten in the process and on disk: ``$BRDFKIT_CACHE_DIR`` is a new
    empty folder (removed afterwards) while the block runs; the tables' disk copies, written
    in the background, are waited for inside the block. The kernels stay compiled in
    memory; with ``check``, a render that compiled or loaded one from disk raises."""
    clear_table_cache()
    before = {name: kernel_cache.STATS[name] for name in ("hits", "misses", "record_misses")}
    previous = os.environ.get(kernel_cache.ENV)
    with tempfile.TemporaryDirectory(prefix="bench-envmap-tables-") as folder:
        os.environ[kernel_cache.ENV] = folder
        try:
            yield
            wait_for_table_store()
        finally:
            if previous is None:
                del os.environ[kernel_cache.ENV]
            else:
                os.environ[kernel_cache.ENV] = previous
    after = {name: kernel_cache.STATS[name] for name in before}
    if check and after != before:
        raise RuntimeError(f"a new scene's render loaded or built kernels: {before} -> {after}")


def peak(path: Path) -> float:
    """The map's brightest texel luminance (Rec. 709)."""
    image = EnvironmentMap.from_file(path).image
    return float((image @ np.array([0.2126, 0.7152, 0.0722], np.float32)).max())


def mitsuba_scene(mi: Any, bsdf: dict[str, Any], path: Path) -> Any:
    """Mitsuba's gold sphere under the map ``path``, read by its own ``envmap`` plugin."""
    to_world = np.eye(4)
    to_world[:3, :3] = ms.MAP_TO_MITSUBA.T
    emitter = {
        "type": "envmap",
        "filename": str(path),
        "to_world": mi.ScalarTransform4f(to_world.tolist()),
    }
    return ms.sphere_scene(mi, bsdf, emitter, RESOLUTION)


def bench_map(mi: Any, path: Path, args: argparse.Namespace) -> dict[str, Any]:
    """Interleaved timings and errors of both renderers, kept and new scenes, on one map."""
    brdf = parse(MODEL)
    bsdf = to_mitsuba_dict(brdf, approximate=True)
    env = EnvironmentMap.from_file(path)
    plan = compiled_shader(brdf, [env], method="auto")
    plan[0].build()
    scene = mitsuba_scene(mi, bsdf, path)

    def brdfkit_new(spp: int, seed: int, check: bool = True) -> np.ndarray:
        with forgotten_tables(check):
            return render_sphere(
                brdf, EnvironmentMap.from_file(path), resolution=RESOLUTION, samples=spp,
                seed=seed, compiled=True,
            )  # fmt: skip

    renderers: dict[str, tuple[str, Callable[[int, int], np.ndarray]]] = {
        "brdfkit kept": ("brdfkit", lambda spp, seed: render_sphere(
            brdf, env, resolution=RESOLUTION, samples=spp, seed=seed, compiled=True)),
        "mitsuba kept": ("mitsuba", lambda spp, seed: ms.render(mi, scene, spp, seed)),
        "brdfkit new": ("brdfkit", brdfkit_new),
        "mitsuba new": ("mitsuba", lambda spp, seed: ms.render(
            mi, mitsuba_scene(mi, bsdf, path), spp, seed)),
        "brdfkit again": ("brdfkit", lambda spp, seed: render_sphere(
            brdf, EnvironmentMap.from_file(path), resolution=RESOLUTION, samples=spp,
            seed=seed, compiled=True)),
    }  # fmt: skip
    mask = interior_mask(RESOLUTION)
    brdfkit_new(4, 12345, check=False)  # warm-up: the table builds' kernels
    for _, render in renderers.values():
        render(4, 12345)  # warm-up: Mitsuba's JIT, brdfkit's kernels
    references = {
        "brdfkit": renderers["brdfkit kept"][1](args.reference, 999),
        "mitsuba": renderers["mitsuba kept"][1](args.reference, 999),
    }
    seconds: dict[str, list[float]] = {name: [] for name in renderers}
    errors: dict[str, list[float]] = {name: [] for name in renderers}
    for repeat in range(args.repeats):
        for name, (peer, render) in renderers.items():
            t, image = timed(lambda r=render, s=1000 + repeat: r(SPP, s))
            seconds[name].append(t)
            errors[name].append(ms.relative_rmse(image, references[peer], mask))
    row: dict[str, Any] = {"map": path.stem.removesuffix("_1k"), "peak": peak(path)}
    for name in renderers:
        t, error = min(seconds[name]), float(np.sqrt(np.mean(np.square(errors[name]))))
        row[name] = {"seconds": t, "rel_rmse": error, "efficiency": 1 / (t * error**2)}
    for mode in ("kept", "new"):
        row[f"ratio {mode}"] = (
            row[f"brdfkit {mode}"]["efficiency"] / row[f"mitsuba {mode}"]["efficiency"]
        )
    row["ratio again"] = row["brdfkit again"]["efficiency"] / row["mitsuba new"]["efficiency"]
    row["reference_agreement"] = ms.relative_rmse(
        references["brdfkit"], references["mitsuba"], mask
    )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BRDFKIT_DATA", "../shared/data"))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--reference", type=int, default=64 * SPP)
    parser.add_argument("--only", nargs="*", help="map names to run (default: all)")
    parser.add_argument("--out", help="results file (default: benchmarks/results/envmap.json)")
    args = parser.parse_args()
    mi, variant = ms.load_mitsuba()
    if variant != "llvm_ad_rgb":
        print(f"Mitsuba's llvm_ad_rgb is unavailable (run benchmarks/setup.sh): using {variant}")
    print(
        "| map | peak | mode | brdfkit s | brdfkit rel. RMSE | Mitsuba s | Mitsuba rel. RMSE "
        "| efficiency brdfkit/Mitsuba |\n|---|---:|---|---:|---:|---:|---:|---:|"
    )
    rows = []
    for name in MAPS:
        if args.only and name not in args.only:
            continue
        row = bench_map(mi, Path(args.data) / "envmaps" / "polyhaven" / f"{name}_1k.hdr", args)
        rows.append(row)
        for mode, peer in (("kept", "kept"), ("new", "new"), ("again", "new")):
            b, m = row[f"brdfkit {mode}"], row[f"mitsuba {peer}"]
            print(
                f"| {row['map']} | {row['peak']:.3g} | {mode} | {b['seconds']:.3f} "
                f"| {b['rel_rmse']:.4f} | {m['seconds']:.3f} | {m['rel_rmse']:.4f} "
                f"| {row[f'ratio {mode}']:.2f} |",
                flush=True,
            )
    from _machine import write_results

    record = {
        "model": MODEL,
        "resolution": RESOLUTION,
        "spp": SPP,
        "reference_spp": args.reference,
        "repeats": args.repeats,
        "mitsuba": f"{mi.__version__} {variant}",
        "rows": rows,
    }
    write_results(__file__, record, args.out, packages=("mitsuba", "drjit"))


if __name__ == "__main__":
    main()
