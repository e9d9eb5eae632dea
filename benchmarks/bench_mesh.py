"""Meshes with shadows, end to end: ``brdfkit render MESH`` against Mitsuba 3's ``direct``.

Scene: :func:`brdfkit.render.mesh.torus_over_plane` (a torus over a ground square, self- and
cast shadows) written as a PLY with its normals, under a real map (``royal_esplanade_1k`` in
Mitsuba's orientation) plus a sun (a directional light, irradiance 3 from (0.5, 1, 0.3)), seen
by ``look_at((0, 2.2, 3.2), (0, 0.4, 0), +y)`` with a 40° horizontal fov, 128×96 pixels.

Per model (gold GGX α = 0.3, a Lambertian clay), each renderer runs at 64 spp as a fresh
process that reads the mesh and the map, renders and writes an EXR: ``brdfkit render`` (the
compiled path, its kernels loaded from the disk cache that the in-process references filled,
with Embree shadow rays) and a Python script that loads the same scene into
Mitsuba (``llvm_ad_rgb`` where it loads, else ``scalar_rgb``; the map read by brdfkit and
given at Mitsuba's texel nodes, as in the oracle tests) and writes its image. Reported:
the process's wall time (best of ``--repeats``), the relative RMSE of its image against the
renderer's *own* converged reference (``--reference`` spp, in process), the efficiency
1/(time·error²) and its ratio to Mitsuba's, and how far the converged images differ (brdfkit
with 4×4 shading points per pixel, Mitsuba's box filter): mean ratio and relative RMSE after
a one-pixel Gaussian blur.

Then a torus of 100k triangles at 512² (gold), the scene kept in process (brdfkit's G-buffer
and Embree scene, Mitsuba's loaded scene), 8 spp, against each renderer's own
``--large-reference``-spp image: brdfkit on its compiled path (float32 tile kernels recording
each sample, Embree's shadow rays in batches between them; the kernels built before timing)
and, for comparison, on its NumPy path.

    python benchmarks/bench_mesh.py [--data ../shared/data] [--repeats 2] [--reference 512]
        [--large-reference 64]

Results go to ``benchmarks/results/mesh.json`` and a Markdown table on stdout.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

from brdfkit.brdf import parse
from brdfkit.interop import mitsuba as ms
from brdfkit.interop import to_mitsuba_dict
from brdfkit.io import read_image
from brdfkit.light import DirectionalLight, EnvironmentMap
from brdfkit.render import shade
from brdfkit.render.mesh import MeshScene, render_mesh, torus_over_plane
from brdfkit.render.mitsuba_frame import look_at_camera, mitsuba_oriented

SIZE = (96, 128)
SPP = 64
LOOK_AT = ((0.0, 2.2, 3.2), (0.0, 0.4, 0.0), (0.0, 1.0, 0.0))
FOV = 40.0
SUN = ((0.5, 1.0, 0.3), 3.0)
LARGE_SECTIONS = 320  # 320 × 160 quads: 102 400 triangles, and the ground's 2
LARGE_PIXELS = 512
LARGE_SPP = 8
MAP = "royal_esplanade_1k.hdr"
MODELS = {
    name: (spec, to_mitsuba_dict(parse(spec)))
    for name, spec in {
        "gold": "ggx(alpha=0.3, material='Au', masking='smith_separable')",
        "clay": "lambertian(albedo=[0.6, 0.5, 0.4])",
    }.items()
}

MITSUBA_SCRIPT = """
import sys, json
sys.path.insert(0, {src!r})
from brdfkit.interop import mitsuba as ms
from brdfkit.interop import to_mitsuba_dict
from brdfkit.light import EnvironmentMap
from brdfkit.render.mitsuba_frame import mitsuba_oriented
mi, variant = ms.load_mitsuba()
args = json.loads(sys.argv[1])
env = mitsuba_oriented(EnvironmentMap.from_file(args["map"]))
emitters = {{
    "sky": ms.envmap_emitter(mi, env),
    "sun": {{"type": "directional", "direction": args["direction"],
             "irradiance": {{"type": "rgb", "value": args["irradiance"]}}}},
}}
scene = ms.mesh_scene(mi, args["mesh"], args["bsdf"], emitters, args["look_at"], args["fov"],
                      args["size"])
mi.util.write_bitmap(args["out"], mi.render(scene, spp=args["spp"], seed=args["seed"]))
print(variant)
"""
"""The Mitsuba process: brdfkit reads the map and gives Mitsuba its values at Mitsuba's own
texel nodes (:func:`brdfkit.interop.mitsuba.envmap_emitter`), so both see the same light."""


def brdfkit_command(mesh: Path, envmap: Path, spec: str, out: Path, spp: int) -> list[str]:
    (ox, oy, oz), (tx, ty, tz), (ux, uy, uz) = LOOK_AT
    (sx, sy, sz), irradiance = SUN
    return [
        sys.executable, "-c", "from brdfkit.cli import main; main()", "render", str(mesh),
        "-b", spec, "-l", f"envmap:{envmap}", "-l", f"directional:{sx},{sy},{sz}:{irradiance}",
        "--look-at", f"{ox},{oy},{oz}:{tx},{ty},{tz}:{ux},{uy},{uz}", "--fov", str(FOV),
        "--size", f"{SIZE[1]}x{SIZE[0]}", "-s", str(spp), "-o", str(out),
    ]  # fmt: skip


def mitsuba_command(mesh: Path, envmap: Path, bsdf: dict, out: Path, spp: int) -> list[str]:
    import json

    direction, irradiance = SUN
    args = {
        "mesh": str(mesh), "map": str(envmap), "bsdf": bsdf, "out": str(out), "spp": spp,
        "seed": 1, "look_at": LOOK_AT, "fov": FOV, "size": SIZE,
        "direction": (-np.asarray(direction) / np.linalg.norm(direction)).tolist(),
        "irradiance": [irradiance] * 3,
    }  # fmt: skip
    src = str(Path(__file__).resolve().parent.parent / "src")
    return [sys.executable, "-c", MITSUBA_SCRIPT.format(src=src), json.dumps(args)]


def run(command: list[str]) -> tuple[float, str]:
    """Wall seconds of a fresh process and its standard output."""
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{command[:4]} failed:\n{done.stderr[-2000:]}")
    return seconds, done.stdout.strip()


def relative_rmse(image: np.ndarray, reference: np.ndarray) -> float:
    return ms.relative_rmse(image, reference, np.ones(image.shape[:2], dtype=bool))


def references(mi, mesh: Path, env: EnvironmentMap, envmap: Path, name: str, spp: int):
    """Each renderer's converged image (brdfkit: pixel centres, and 4×4 points per pixel)."""
    spec, bsdf = MODELS[name]
    scene = MeshScene.from_file(mesh)
    camera = look_at_camera(*LOOK_AT, fov=FOV, size=SIZE)
    lights = [mitsuba_oriented(env), DirectionalLight(*SUN)]
    centres = render_mesh(scene, parse(spec), lights, camera, SIZE, samples=spp, seed=7)
    boxed = render_mesh(
        scene, parse(spec), lights, camera, SIZE, supersample=4, samples=max(spp // 16, 1)
    )
    emitters = {
        "sky": ms.envmap_emitter(mi, mitsuba_oriented(env)),
        "sun": ms.directional_emitter(DirectionalLight(*SUN)),
    }
    mi_scene = ms.mesh_scene(mi, mesh, bsdf, emitters, LOOK_AT, FOV, SIZE)
    mitsuba = ms.render(mi, mi_scene, spp, seed=7)
    return centres, boxed, mitsuba


def bench_model(mi, name: str, paths: dict[str, Path], env, args) -> dict:
    spec, bsdf = MODELS[name]
    centres, boxed, mitsuba_ref = references(
        mi, paths["mesh"], env, paths["map"], name, args.reference
    )
    out = {
        "brdfkit": paths["tmp"] / f"{name}-brdfkit.exr",
        "mitsuba": paths["tmp"] / f"{name}-mitsuba.exr",
    }
    commands = {
        "brdfkit": brdfkit_command(paths["mesh"], paths["map"], spec, out["brdfkit"], SPP),
        "mitsuba": mitsuba_command(paths["mesh"], paths["map"], bsdf, out["mitsuba"], SPP),
    }
    seconds: dict[str, list[float]] = {"brdfkit": [], "mitsuba": []}
    variant = ""
    for _ in range(args.repeats):
        for who, command in commands.items():
            t, stdout = run(command)
            seconds[who].append(t)
            variant = stdout.splitlines()[-1] if who == "mitsuba" else variant
    row: dict = {"model": name, "spp": SPP, "mitsuba_variant": variant}
    for who, reference in (("brdfkit", centres), ("mitsuba", mitsuba_ref)):
        t = min(seconds[who])
        error = relative_rmse(read_image(out[who]).astype(float), reference)
        row[who] = {"seconds": t, "rel_rmse": error, "efficiency": 1 / (t * error**2)}
    row["efficiency_ratio"] = row["brdfkit"]["efficiency"] / row["mitsuba"]["efficiency"]
    row["reference_mean_ratio"] = float(boxed.mean() / mitsuba_ref.mean())
    blur = (gaussian_filter(x, (1, 1, 0)) for x in (boxed, mitsuba_ref))
    row["reference_blurred_rel_rmse"] = relative_rmse(*blur)
    return row


def bench_large(mi, env: EnvironmentMap, tmp: Path, args) -> dict:
    """A torus of about 100k triangles over the plane at 512², gold, the scene kept in
    process: brdfkit's G-buffer and Embree scene built once, Mitsuba's scene loaded once; the
    best of ``--repeats`` renders at ``LARGE_SPP`` against each renderer's own
    ``--large-reference``-spp image (brdfkit's NumPy path against the compiled path's: the
    same estimator, so the same expected image), the renderers interleaved per repeat."""
    spec, bsdf = MODELS["gold"]
    mesh = tmp / "large.ply"
    large = torus_over_plane(sections=LARGE_SECTIONS)
    large.export(mesh, vertex_normal=True)
    size = (LARGE_PIXELS, LARGE_PIXELS)
    scene = MeshScene.from_file(mesh)
    camera = look_at_camera(*LOOK_AT, fov=FOV, size=size)
    g = scene.gbuffer(camera, size)  # kept: the scene's per-view work
    lights = [mitsuba_oriented(env), DirectionalLight(*SUN)]
    model, visibility = parse(spec), scene.visibility(g)
    emitters = {
        "sky": ms.envmap_emitter(mi, mitsuba_oriented(env)),
        "sun": ms.directional_emitter(DirectionalLight(*SUN)),
    }
    mi_scene = ms.mesh_scene(mi, mesh, bsdf, emitters, LOOK_AT, FOV, size)

    def brdfkit(compiled: bool):
        return lambda spp, seed: shade(
            g, model, lights, samples=spp, seed=seed, visibility=visibility, compiled=compiled
        )

    renderers = {
        "brdfkit": brdfkit(True),
        "brdfkit_numpy": brdfkit(False),
        "mitsuba": lambda spp, seed: ms.render(mi, mi_scene, spp, seed),
    }
    references = {who: renderers[who](args.large_reference, 99) for who in ("brdfkit", "mitsuba")}
    references["brdfkit_numpy"] = references["brdfkit"]
    seconds: dict[str, list[float]] = {who: [] for who in renderers}
    errors: dict[str, list[float]] = {who: [] for who in renderers}
    for repeat in range(args.repeats):
        for who, render in renderers.items():
            start = time.perf_counter()
            image = render(LARGE_SPP, repeat + 1)
            seconds[who].append(time.perf_counter() - start)
            errors[who].append(relative_rmse(image, references[who]))
    row: dict = {"model": "gold", "triangles": len(large.faces), "size": list(size)}
    for who in renderers:
        t, error = min(seconds[who]), float(np.sqrt(np.mean(np.square(errors[who]))))
        row[who] = {"seconds": t, "rel_rmse": error, "efficiency": 1 / (t * error**2)}
    row["spp"], row["reference_spp"] = LARGE_SPP, args.large_reference
    row["efficiency_ratio"] = row["brdfkit"]["efficiency"] / row["mitsuba"]["efficiency"]
    row["efficiency_ratio_numpy"] = (
        row["brdfkit_numpy"]["efficiency"] / row["mitsuba"]["efficiency"]
    )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BRDFKIT_DATA", "../shared/data"))
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--reference", type=int, default=512)
    parser.add_argument("--large-reference", type=int, default=64)
    parser.add_argument("--out", help="results file (default: benchmarks/results/mesh.json)")
    args = parser.parse_args()
    mi, variant = ms.load_mitsuba()
    envmap = Path(args.data) / "envmaps" / "polyhaven" / MAP
    env = EnvironmentMap.from_file(envmap)
    print(
        "| model | spp | brdfkit s | brdfkit rel. RMSE | Mitsuba s | Mitsuba rel. RMSE "
        "| efficiency brdfkit/Mitsuba | converged mean ratio | converged blurred rel. RMSE |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        mesh = Path(tmp) / "torus.ply"
        torus_over_plane(sections=64).export(mesh, vertex_normal=True)
        paths = {"mesh": mesh, "map": envmap, "tmp": Path(tmp)}
        for name in MODELS:
            r = bench_model(mi, name, paths, env, args)
            rows.append(r)
            b, m = r["brdfkit"], r["mitsuba"]
            print(
                f"| {name} | {SPP} | {b['seconds']:.2f} | {b['rel_rmse']:.4f} | "
                f"{m['seconds']:.2f} | {m['rel_rmse']:.4f} | **{r['efficiency_ratio']:.2f}** | "
                f"{r['reference_mean_ratio']:.4f} | {r['reference_blurred_rel_rmse']:.4f} |",
                flush=True,
            )
        large = bench_large(mi, env, Path(tmp), args)
    b, n, m = large["brdfkit"], large["brdfkit_numpy"], large["mitsuba"]
    print(
        f"\n{large['triangles']} triangles at {LARGE_PIXELS}², scene kept, {LARGE_SPP} spp: "
        f"brdfkit compiled {b['seconds']:.2f} s (error {b['rel_rmse']:.4f}), NumPy "
        f"{n['seconds']:.2f} s (error {n['rel_rmse']:.4f}), Mitsuba {m['seconds']:.2f} s "
        f"(error {m['rel_rmse']:.4f}): efficiency brdfkit/Mitsuba "
        f"{large['efficiency_ratio']:.2f} compiled, {large['efficiency_ratio_numpy']:.2f} NumPy"
    )
    from _machine import write_results

    record = {
        "size": list(SIZE),
        "reference_spp": args.reference,
        "repeats": args.repeats,
        "envmap": MAP,
        "mitsuba": f"{mi.__version__} {variant}",
        "rows": rows,
        "large": large,
    }
    write_results(__file__, record, args.out, packages=("mitsuba", "drjit", "trimesh", "embreex"))


if __name__ == "__main__":
    main()
