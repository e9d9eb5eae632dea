"""How long ``brdfkit atlas`` takes with its defaults, and how noisy its env-map spheres are.

Time: :func:`brdfkit.report.build_atlas` with the CLI's defaults (every model of
``DEFAULT_MODELS``, the bundled map, 96² spheres, 32 spp under the sun, environment-lit spheres
refined to an estimated 1 %, checks on), ``--repeats`` times; the minimum, the CPU seconds of
the process and its workers (robust to other load) and the import time are reported (the goal:
under 15 s on 2 cores). ``--cold`` first builds once on an empty kernel cache
(``BRDFKIT_CACHE_DIR`` a new temporary folder: every kernel traced and compiled), then the
repeats run warm on it; without it the repeats use the user's cache as it is.

Noise: every sphere of every default card under the environment map. The atlas's own choice of
samples N is made at its resolution (:func:`brdfkit.report.env_sphere`, seed 1); the same
passes totalling N spp are then rendered at ``--noise-resolution`` (per-pixel noise does not
depend on the resolution; the default is the atlas's own) and compared with a render at 16 N
spp with another seed, inside the silhouette (:func:`~brdfkit.interop.mitsuba.relative_rmse`;
the goal: every sphere under 1 %). A sphere :func:`~brdfkit.render.quadrature_sphere`
renders (no noise) is compared instead with (a) the quadrature one level finer at the atlas's
resolution (2× the rows, columns and rings: 8× the kernel nodes) and (b) Monte Carlo at
``--noise-resolution`` from two seeds of ``--mc-samples``/2 spp each (their half difference
estimates the reference's own noise, reported alongside), against the quadrature at the same
level there.

Objects (``--objects``): the default atlas without and with the cards' object images
(:func:`brdfkit.report.atlas.object_image`, ``brdfkit atlas --objects``), alternating,
``--repeats`` pairs: wall and CPU seconds and their median ratio.

Profile (``--profile``): the CPU seconds of each part of each card (directional spheres,
environment spheres, plots, checks), cards built one after another (with one BLAS thread, as
the atlas's processes), and of each
environment-lit sphere, marked "(NumPy)" where its compiled kernels were not there (cold).

    python benchmarks/bench_atlas.py [--repeats 1] [--cold] [--noise-resolution 96]
        [--skip-noise] [--profile] [--objects] [--only CARD ...] [--json]

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


def time_atlas(
    repeats: int, cold: bool, goal: dict | None = None
) -> tuple[list[float], list[float], list[str]]:
    """Wall and CPU seconds of each atlas build and whether it ran on a cold or warm cache."""
    from brdfkit.compiled import cache as kernel_cache
    from brdfkit.report.atlas import build_atlas

    seconds, cpu, cache = [], [], []
    saved = os.environ.get(kernel_cache.ENV)
    with tempfile.TemporaryDirectory() as folder:
        if cold:
            os.environ[kernel_cache.ENV] = str(Path(folder) / "kernels")
        for k in range(repeats + cold):
            start, start_cpu = time.perf_counter(), _cpu_seconds()
            build_atlas(Path(folder) / "index.html", **(goal or {}))
            seconds.append(time.perf_counter() - start)
            cpu.append(_cpu_seconds() - start_cpu)
            cache.append("cold" if cold and k == 0 else "warm" if cold else "user")
            print(f"  atlas ({cache[-1]} cache): {seconds[-1]:.1f} s, {cpu[-1]:.1f} CPU s")
    if cold and saved is None:
        os.environ.pop(kernel_cache.ENV)
    elif cold:
        os.environ[kernel_cache.ENV] = saved
    return seconds, cpu, cache


def time_objects(repeats: int) -> dict:
    """Wall and CPU seconds of the default atlas without and with its object images
    (``objects=True``), alternating, ``repeats`` pairs; the median ratio with / without."""
    from brdfkit.report.atlas import build_atlas

    runs: dict[str, dict[str, list[float]]] = {
        k: {"seconds": [], "cpu_seconds": []} for k in ("without", "with")
    }
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(repeats):
            for key, objects in (("without", False), ("with", True)):
                start, start_cpu = time.perf_counter(), _cpu_seconds()
                build_atlas(Path(folder) / "index.html", objects=objects)
                runs[key]["seconds"].append(time.perf_counter() - start)
                runs[key]["cpu_seconds"].append(_cpu_seconds() - start_cpu)
                print(f"  atlas {key} objects: {runs[key]['seconds'][-1]:.1f} s, "
                      f"{runs[key]['cpu_seconds'][-1]:.1f} CPU s")  # fmt: skip
    ratio = {
        f"{k}_ratio": float(np.median(np.divide(runs["with"][k], runs["without"][k])))
        for k in ("seconds", "cpu_seconds")
    }
    return {**runs, **ratio, "repeats": repeats}


def profile_atlas(only: list[str] | None = None) -> dict:
    """CPU seconds of each part of every default card (the construction of its examples, then
    :attr:`brdfkit.report.Card.cpu_seconds`), built one after another in this process, and of
    each environment-lit sphere, with whether compiled kernels were there for it (built, or
    in the kernel cache: the warm path) or not (NumPy: a cold cache; the default atlas never
    builds them, its spheres are too small)."""
    from brdfkit.data import default_envmap_path
    from brdfkit.light import EnvironmentMap
    from brdfkit.render.compiled_shading import compiled_shader
    from brdfkit.report.atlas import _registered_defaults, build_card, default_examples

    env = EnvironmentMap.from_file(default_envmap_path())
    start = time.process_time()
    _ = env.irradiance_table
    parts: dict[str, float] = {"irradiance table": time.process_time() - start}
    cards = []
    for title in _registered_defaults():
        if only and title not in only:
            continue
        start = time.process_time()
        models = default_examples(title)
        made = time.process_time() - start
        warm = [compiled_shader(m, [env], method="auto", build=False) is not None for m in models]
        card = build_card(title, models, envmap=env, resolution=RESOLUTION, samples=SAMPLES)
        card_parts = {"examples": made, **card.cpu_seconds}
        for part, seconds in card_parts.items():
            parts[part] = parts.get(part, 0.0) + seconds
        spheres = [
            f"{s:.2f}{'' if w else ' (NumPy)'}"
            for s, w in zip(card.env_cpu_seconds, warm, strict=True)
        ]
        total = sum(card_parts.values())
        print(f"  {title}: " + ", ".join(f"{k} {v:.2f}" for k, v in card_parts.items())
              + f"; total {total:.2f}; env spheres {', '.join(spheres)} CPU s")  # fmt: skip
        cards.append(
            {"card": title, "cpu_seconds": card_parts, "total_cpu_seconds": total,
             "env_cpu_seconds": card.env_cpu_seconds, "env_compiled": warm}
        )  # fmt: skip
    print("  CPU s per part: " + ", ".join(f"{k} {v:.1f}" for k, v in parts.items())
          + f"; total {sum(parts.values()):.1f}")  # fmt: skip
    return {"parts": parts, "cards": cards}


def _quadrature_row(title, k, model, env, resolution, cpu, goal, mc_samples) -> dict:
    """A quadrature sphere's errors against (a) the next level and (b) Monte Carlo."""
    from brdfkit.interop.mitsuba import relative_rmse
    from brdfkit.render import quadrature_sphere, render_sphere
    from brdfkit.render.environment_quadrature import GOAL
    from brdfkit.render.scene import interior_mask

    q = quadrature_sphere(model, env, RESOLUTION, goal=(goal or {}).get("noise") or GOAL)
    finer = quadrature_sphere(model, env, RESOLUTION, level=q.level + 1)
    mask = interior_mask(RESOLUTION)
    ref = finer.image
    error_a = relative_rmse(q.image, ref, mask) if np.any(ref[mask]) else 0.0
    small = quadrature_sphere(model, env, resolution, level=q.level, gammas=q.gammas).image
    a, b = (
        render_sphere(model, env, resolution, samples=mc_samples // 2, seed=s, compiled=True)
        for s in (2, 3)
    )
    mask = interior_mask(resolution)
    mc = (a + b) / 2
    nonzero = np.any(mc[mask])
    error_b = relative_rmse(small, mc, mask) if nonzero else 0.0
    noise_b = relative_rmse(a, b, mask) / 2 if nonzero else 0.0
    print(
        f"  {title} #{k + 1}: quadrature level {q.level}, {q.nodes} nodes ({cpu:.2f} CPU s); "
        f"vs level {q.level + 1}: {error_a:.4f}; vs MC {mc_samples} spp at {resolution}²: "
        f"{error_b:.4f} (MC noise {noise_b:.4f})"
    )
    return {
        "card": title, "example": k, "rel_rmse": max(error_a, error_b), "spp": 0,
        "quadrature_nodes": q.nodes, "quadrature_level": q.level, "cpu_seconds": cpu,
        "rel_rmse_finer_quadrature": error_a, "rel_rmse_mc": error_b, "mc_noise": noise_b,
        "mc_samples": mc_samples, "mc_resolution": resolution,
    }  # fmt: skip


def sphere_noise(
    resolution: int,
    only: list[str] | None = None,
    goal: dict | None = None,
    mc_samples: int = 2048,
) -> list[dict]:
    from brdfkit.data import default_envmap_path
    from brdfkit.interop.mitsuba import relative_rmse
    from brdfkit.light import EnvironmentMap
    from brdfkit.render import render_sphere
    from brdfkit.render.scene import interior_mask
    from brdfkit.report.atlas import default_cards, env_sphere

    env = EnvironmentMap.from_file(default_envmap_path())
    mask = interior_mask(resolution)
    rows = []
    for title, models in default_cards():
        if only and title not in only:
            continue
        for k, model in enumerate(models):
            start = time.process_time()
            image, spp = env_sphere(model, env, RESOLUTION, samples=SAMPLES, seed=1, **(goal or {}))
            cpu = time.process_time() - start
            if isinstance(spp, str):  # the quadrature: no noise; against (a) and (b)
                rows.append(
                    _quadrature_row(title, k, model, env, resolution, cpu, goal, mc_samples)
                )
                continue
            if resolution != RESOLUTION:  # the same passes, N spp in all, smaller
                image, _ = env_sphere(
                    model, env, resolution, samples=SAMPLES, noise=0.0, max_samples=spp, seed=1
                )
            reference = render_sphere(
                model, env, resolution, samples=16 * spp, seed=2, compiled=True
            )
            error = relative_rmse(image, reference, mask) if np.any(reference[mask]) else 0.0
            rows.append(
                {"card": title, "example": k, "rel_rmse": error, "spp": spp, "cpu_seconds": cpu}
            )
            print(f"  {title} #{k + 1}: {spp} spp, rel. RMSE {error:.4f} ({cpu:.2f} CPU s)")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--cold", action="store_true", help="first build on an empty cache")
    parser.add_argument("--noise-resolution", type=int, default=RESOLUTION)
    parser.add_argument("--skip-noise", action="store_true")
    parser.add_argument(
        "--mc-samples", type=int, default=2048, help="MC reference spp of quadrature spheres"
    )
    parser.add_argument(
        "--profile", action="store_true", help="first the CPU seconds of each card's parts"
    )
    parser.add_argument(
        "--only", nargs="+", help="noise and profile of these cards only (e.g. ggx)"
    )
    parser.add_argument(
        "--objects", action="store_true", help="time the atlas without and with object images"
    )
    parser.add_argument("--json", action="store_true", help="print the record as JSON")
    parser.add_argument("--out", help="results file (default: benchmarks/results/atlas.json)")
    parser.add_argument(
        "--noise-goal", type=float, help="not the default: the atlas's --noise (e.g. 0.01)"
    )
    parser.add_argument(
        "--max-samples", type=int, help="not the default: the atlas's --max-samples with a goal"
    )
    args = parser.parse_args()
    goal = {}
    if args.noise_goal is not None:
        goal["noise"] = args.noise_goal
    if args.max_samples is not None:
        goal["max_samples"] = args.max_samples
    import matplotlib

    matplotlib.use("Agg")
    start = time.perf_counter()
    import brdfkit.report.atlas  # noqa: F401

    import_seconds = time.perf_counter() - start
    record: dict = {
        "host": f"{platform.machine()}, {len(os.sched_getaffinity(0))} cores usable, "
        f"{platform.python_version()}",
        "import_seconds": import_seconds,
        "options": goal or "defaults",
    }
    if args.profile:
        from threadpoolctl import threadpool_limits

        print("CPU seconds of each part, cards one after another in this process:")
        with threadpool_limits(1, user_api="blas"):  # as the atlas's processes
            record["profile"] = profile_atlas(args.only)
    if not args.skip_noise:
        print(f"noise at the atlas's spp N against 16 N spp, {args.noise_resolution}²:")
        rows = sphere_noise(args.noise_resolution, args.only, goal, args.mc_samples)
        record["noise"] = {"resolution": args.noise_resolution, "spheres": rows}
    if args.objects:
        print("the atlas without and with its object images, alternating:")
        record["objects"] = time_objects(args.repeats)
    seconds, cpu, cache = time_atlas(args.repeats, args.cold, goal)
    record["atlas_seconds"] = seconds
    record["atlas_cpu_seconds"] = cpu
    record["atlas_cache"] = cache
    record["load_average"] = os.getloadavg()
    if args.json:
        print(json.dumps(record, indent=2))
    else:
        warm = [k for k, c in enumerate(cache) if c != "cold"] or list(range(len(cache)))
        if warm:  # --repeats 0 without --cold: noise only
            best = min(seconds[k] for k in warm)
            verdict = "met" if best < GOAL_SECONDS else "NOT met"
            print(
                f"atlas ({cache[warm[0]]} cache): {best:.1f} s, {min(cpu[k] for k in warm):.1f} "
                f"CPU s (import {import_seconds:.1f} s, load average {os.getloadavg()[0]:.1f}): "
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
    from _machine import write_results

    write_results(__file__, record, args.out)


if __name__ == "__main__":
    main()
