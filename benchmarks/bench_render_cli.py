"""The command line as a user meets it: ``brdfkit render`` against Mitsuba 3's whole process.

``brdfkit render -b "ggx(alpha=0.3, material='Au')"`` with its defaults (a 256² sphere, 64 spp,
the bundled map), writing an EXR (``-o warm.exr``, as Mitsuba's command writes one), as a fresh
process, against Mitsuba's own command line
(``mitsuba -m VARIANT -o out.exr scene.xml``: import, load, render, write) on the twin scene:
the unit sphere seen by brdfkit's orthographic camera, ``roughconductor`` GGX α = 0.3 gold
(:func:`brdfkit.interop.to_mitsuba_xml`, Mitsuba's separable masking the nearest), the bundled
map as an EXR of its values at Mitsuba's texel nodes
(:func:`brdfkit.interop.mitsuba.envmap_texels`, written once before the runs), the ``direct``
integrator, 64 spp, ``llvm_ad_rgb`` where it loads, else ``scalar_rgb``.

Two figures:

- **warm**: the kernel cache (``BRDFKIT_CACHE_DIR``, a folder of this run's own) filled by one
  run first, then ``--repeats`` runs of each, interleaved (brdfkit, Mitsuba, brdfkit, …),
  wall seconds of each process; the median of each and of the pairwise ratios; and the CPU
  seconds (user + system, all threads) of each process, which the machine's other work
  inflates far less than the wall time;
- **first**: ``--cold`` runs each with an empty kernel cache (a new folder each time): the
  very first render a new user waits for, its kernel build announced on stderr; with
  ``--baseline SRC`` (the ``src`` folder of another brdfkit checkout) each is paired with a
  cold run of that code, in alternating order, and the load average before each run is kept;
  each cold image is checked to equal the warm one (the same machine code, built by the
  worker process or loaded). One untimed cold run of each code first fills Python's
  bytecode cache, which an installed package has.

With ``--baseline`` the warm runs are triples: brdfkit, the baseline (its kernel cache filled
by its first cold run) and Mitsuba, and the baseline's images are compared with brdfkit's.

Both processes run as installed packages do, with their modules' bytecode cached
(``PYTHONPYCACHEPREFIX``, a folder of this run's own, filled by the first runs; an environment
with ``PYTHONDONTWRITEBYTECODE`` would otherwise compile every module of brdfkit from source in
every process).

A sanity check of the twin (not timed): both renderers' linear images of the scene, their
mean ratio over the sphere.

    python benchmarks/bench_render_cli.py [--repeats 7] [--cold 2] [--baseline SRC]

Results go to ``benchmarks/results/render_cli.json`` and a summary on stdout.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from brdfkit.brdf import parse
from brdfkit.interop import mitsuba as ms
from brdfkit.interop import to_mitsuba_xml
from brdfkit.io import read_image
from brdfkit.light.spec import parse_light
from brdfkit.render.scene import interior_mask

SPEC = "ggx(alpha=0.3, material='Au')"
RESOLUTION = 256
"""``brdfkit render``'s default image size."""
SPP = 64
"""``brdfkit render``'s default samples per pixel."""

SCENE = """<scene version="3.0.0">
  <integrator type="direct"><boolean name="hide_emitters" value="true"/></integrator>
  <sensor type="orthographic">
    <transform name="to_world"><lookat origin="10, 0, 0" target="0, 0, 0" up="0, 0, 1"/>
    </transform>
    <film type="hdrfilm">
      <integer name="width" value="{resolution}"/><integer name="height" value="{resolution}"/>
      <string name="pixel_format" value="rgb"/><rfilter type="box"/>
    </film>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
  </sensor>
  <shape type="sphere">
{bsdf}
  </shape>
  <emitter type="envmap">
    <string name="filename" value="{envmap}"/>
    <transform name="to_world"><matrix value="{to_world}"/></transform>
  </emitter>
</scene>
"""
"""The twin of ``brdfkit render``'s default sphere (as :func:`brdfkit.interop.mitsuba.sphere_scene`
builds it in process)."""


def write_scene(folder: Path, mi) -> Path:
    """The Mitsuba scene file of the twin scene and its map's EXR, in ``folder``."""
    env = parse_light("envmap")
    envmap = folder / "map.exr"
    mi.Bitmap(ms.envmap_texels(env)).write(str(envmap))
    to_world = np.eye(4)
    to_world[:3, :3] = env.rotation @ ms.MAP_TO_MITSUBA.T
    bsdf = to_mitsuba_xml(parse(SPEC), approximate=True).replace(' version="3.0.0"', "")
    scene = folder / "scene.xml"
    matrix = " ".join(f"{x:.17g}" for x in to_world.ravel())
    text = SCENE.format(resolution=RESOLUTION, spp=SPP, bsdf=bsdf, envmap=envmap, to_world=matrix)
    scene.write_text(text, encoding="utf-8")
    return scene


def run(
    command: list[str], cwd: Path, cache: Path | None = None, source: str | None = None
) -> tuple[float, float, str]:
    """Wall and CPU seconds of ``command`` as a fresh process in ``cwd`` and its standard
    error; ``cache`` is brdfkit's kernel cache folder for it, ``source`` a brdfkit ``src``
    folder to import instead of the installed one. Python's bytecode is cached under ``cwd``."""
    env = dict(os.environ)
    if source is not None:
        env["PYTHONPATH"] = source
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPYCACHEPREFIX"] = str(cwd / "bytecode")
    if cache is not None:
        env["BRDFKIT_CACHE_DIR"] = str(cache)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{command[:3]} failed:\n{done.stderr[-2000:]}{done.stdout[-2000:]}")
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return seconds, cpu, done.stderr


def _commit(source: str) -> str:
    """The git commit of the checkout holding ``source``, or ``source`` itself outside git."""
    done = subprocess.run(["git", "-C", source, "rev-parse", "--short=12", "HEAD"],
                          capture_output=True, text=True, check=False)  # fmt: skip
    return done.stdout.strip() or source


def brdfkit_command(*extra: str) -> list[str]:
    """``brdfkit render -b SPEC`` with its defaults (the console script's own entry point)."""
    return [sys.executable, "-c", "from brdfkit.cli import main; main()", "render", "-b", SPEC,
            *extra]  # fmt: skip


def twin_check(folder: Path, scene: Path, variant: str, cache: Path) -> float:
    """Mean ratio brdfkit ÷ Mitsuba of the two linear images over the sphere."""
    run(brdfkit_command("-o", "check.exr"), folder, cache)
    run(["mitsuba", "-m", variant, "-o", str(folder / "check_mitsuba.exr"), str(scene)], folder)
    mask = interior_mask(RESOLUTION)
    ours = read_image(folder / "check.exr")[..., :3][mask].mean()
    theirs = read_image(folder / "check_mitsuba.exr")[..., :3][mask].mean()
    return float(ours / theirs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--cold", type=int, default=2)
    parser.add_argument("--baseline", help="src folder of a brdfkit to pair cold runs with")
    parser.add_argument("--out", help="results file (default: benchmarks/results/render_cli.json)")
    args = parser.parse_args()
    mi, variant = ms.load_mitsuba()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene = write_scene(folder, mi)
        mitsuba = ["mitsuba", "-m", variant, "-o", str(folder / "mitsuba.exr"), str(scene)]
        first, announced, baseline, loads = [], [], [], []
        for source in (None, args.baseline) if args.baseline else (None,):  # bytecode
            run(brdfkit_command("-o", "untimed.exr"), folder, folder / "untimed", source)
        for k in range(args.cold):
            for turn in (k % 2, 1 - k % 2) if args.baseline else (0,):
                loads.append(os.getloadavg()[0])
                cache = folder / (f"cold{k}" if turn == 0 else f"baseline{k}")
                output = f"cold{k}.exr" if turn == 0 else f"baseline{k}.exr"
                seconds, _, stderr = run(
                    brdfkit_command("-o", output), folder, cache, (None, args.baseline)[turn]
                )
                (first if turn == 0 else baseline).append(seconds)
                if turn == 0:
                    announced.append(stderr.strip())
                print(f"first render (empty kernel cache){' baseline' * turn}: {seconds:.2f} s")
        warm = folder / "cold0"  # filled by the first cold run
        if not args.cold:  # no cold run: fill it now, untimed
            run(brdfkit_command("-o", "untimed.exr"), folder, warm)
        run(mitsuba, folder)  # Mitsuba's own caches (LLVM kernels) warm too
        ours, theirs, our_cpu, their_cpu, base, base_cpu = [], [], [], [], [], []
        for _ in range(args.repeats):
            seconds, cpu, _ = run(brdfkit_command("-o", "warm.exr"), folder, warm)
            ours.append(seconds)
            our_cpu.append(cpu)
            if args.baseline:
                seconds, cpu, _ = run(
                    brdfkit_command("-o", "warm_baseline.exr"), folder, folder / "baseline0",
                    args.baseline,
                )  # fmt: skip
                base.append(seconds)
                base_cpu.append(cpu)
                print(f"warm: baseline {seconds:.2f} s ({cpu:.2f} CPU s)", flush=True)
            seconds, cpu, _ = run(mitsuba, folder)
            theirs.append(seconds)
            their_cpu.append(cpu)
            print(f"warm: brdfkit {ours[-1]:.2f} s ({our_cpu[-1]:.2f} CPU s), Mitsuba "
                  f"{theirs[-1]:.2f} s ({their_cpu[-1]:.2f} CPU s)", flush=True)  # fmt: skip
        ratio = twin_check(folder, scene, variant, warm)
        image = read_image(folder / "warm.exr")
        cold_equal = [
            bool(np.array_equal(read_image(folder / f"cold{k}.exr"), image))
            for k in range(args.cold)
        ]
        if args.baseline:
            difference = np.abs(read_image(folder / "warm_baseline.exr") - image)
            base_difference = float(difference.max())
    ratios = [a / b for a, b in zip(ours, theirs, strict=True)]
    paired, warm_paired = {}, {}
    if args.baseline:
        paired = {"baseline_seconds": baseline, "baseline": _commit(args.baseline)}
        warm_paired = {
            "baseline_seconds": base,
            "baseline_median": statistics.median(base),
            "baseline_cpu_seconds": base_cpu,
            "baseline_image_max_abs_difference": base_difference,
        }
    record = {
        "spec": SPEC,
        "resolution": RESOLUTION,
        "spp": SPP,
        "mitsuba": f"{mi.__version__} {variant}",
        "warm": {
            "brdfkit_seconds": ours,
            "mitsuba_seconds": theirs,
            "brdfkit_median": statistics.median(ours),
            "mitsuba_median": statistics.median(theirs),
            "ratio_median": statistics.median(ratios),
            "brdfkit_cpu_seconds": our_cpu,
            "mitsuba_cpu_seconds": their_cpu,
            "brdfkit_cpu_median": statistics.median(our_cpu),
            "mitsuba_cpu_median": statistics.median(their_cpu),
        }
        | warm_paired,
        "first": {
            "seconds": first,
            "stderr": announced,
            "load_before_runs": loads,
            "load_after": os.getloadavg()[0],
            "image_equals_warm": cold_equal,
        }
        | paired,
        "twin_mean_ratio": ratio,
    }
    w = record["warm"]
    print(
        f"warm medians: brdfkit {w['brdfkit_median']:.2f} s, Mitsuba {w['mitsuba_median']:.2f} s, "
        f"ratio {w['ratio_median']:.2f}; CPU brdfkit {w['brdfkit_cpu_median']:.2f} s, Mitsuba "
        f"{w['mitsuba_cpu_median']:.2f} s"
        + (
            f"; first render median {statistics.median(first):.2f} s, at most {max(first):.2f} s"
            if first
            else ""
        )
        + (f" (baseline median {statistics.median(baseline):.2f} s)" if baseline else "")
        + f"; twin mean ratio {ratio:.4f}"
    )
    from _machine import write_results

    write_results(__file__, record, args.out, packages=("mitsuba", "drjit"))


if __name__ == "__main__":
    main()
