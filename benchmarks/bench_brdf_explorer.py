"""BRDF Explorer's 40 analytic files through the GLSL translator: cost and physics.

For every ``.brdf`` file of BRDF Explorer's distribution (``brdf_explorer/`` of the shared
data), at its default parameters, on 100 000 random pairs of directions above the surface
(float64 NumPy): the time of one ``eval`` (best of 3), the share of finite values, the
largest reciprocity difference max|f(wi, wo) − f(wo, wi)| / max f, and the largest directional
albedo over θo ∈ {0°, 30°, 60°, 80°} (4096 cosine-weighted samples each, the mean of the
channels); and, where moderngl and Mesa's EGL are installed (the ``glsl-oracle`` extra), the
shader run by OpenGL itself (Mesa's llvmpipe, float32, on the first 4096 pairs rounded to
float32; ``tests/interop/_opengl.py``): max|OpenGL − brdfkit| / max|brdfkit| over the pairs
that OpenGL computes finitely, and the share it does not. Then the translated shaders against
brdfkit's own code for the same formula (``walter.brdf`` against
``ggx(masking='smith_separable')``, ``lambert.brdf`` against ``lambertian``): the largest
relative difference and the time ratio.

    python benchmarks/bench_brdf_explorer.py [--data ../shared/data] [--pairs 100000]
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit import io
from brdfkit.brdf import parse
from brdfkit.interop.brdf_explorer import read_brdf_explorer

THETA_O = (0.0, 30.0, 60.0, 80.0)
OPENGL_PAIRS = 4096
ORACLE = Path(__file__).resolve().parents[1] / "tests" / "interop" / "_opengl.py"
PEERS = {
    "walter.brdf": ({"Kd": 0.0, "Ks": 1.0, "alphaG": 0.1},
                    "ggx(alpha=0.1, material='none', masking='smith_separable')"),
    "lambert.brdf": ({}, "lambertian(rho=1.0)"),
}  # fmt: skip


def directions(n: int, rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def best_time(function, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def opengl() -> tuple[Any, Any] | None:
    """The OpenGL oracle of the tests (its module and a context), or ``None`` without one."""
    try:
        import moderngl

        ctx = moderngl.create_standalone_context(backend="egl", require=430)
    except Exception as error:  # moderngl raises a bare Exception where EGL is missing
        print(f"no OpenGL comparison: {error}")
        return None
    spec = importlib.util.spec_from_file_location("opengl_oracle", ORACLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module, ctx


def compare_opengl(oracle: tuple[Any, Any], brdf: Any, wi: np.ndarray, wo: np.ndarray) -> dict:
    module, ctx = oracle
    wi32, wo32 = (w[:OPENGL_PAIRS].astype(np.float32).astype(np.float64) for w in (wi, wo))
    theirs = module.opengl_values(ctx, brdf, wi32, wo32)
    ours = brdf.shader_value(wi32, wo32)
    finite = np.isfinite(theirs).all(axis=-1)
    scale = float(np.max(np.abs(ours[finite])))
    difference = float(np.max(np.abs(theirs - ours)[finite]))
    return {"opengl_error": difference / scale if scale > 0 else difference,
            "opengl_nonfinite": float(1 - np.mean(finite))}  # fmt: skip


def measure(path: Path, wi: np.ndarray, wo: np.ndarray, oracle: tuple | None) -> dict:
    brdf = read_brdf_explorer(path)
    seconds = best_time(lambda: brdf.eval(wi, wo))
    f, f_swapped = brdf.eval(wi, wo), brdf.eval(wo, wi)
    finite = np.isfinite(f).all(axis=-1) & np.isfinite(f_swapped).all(axis=-1)
    scale = float(np.max(f[finite])) if finite.any() else 0.0
    difference = float(np.max(np.abs(f - f_swapped)[finite])) if finite.any() else math.nan
    thetas = np.radians(THETA_O)
    wo_albedo = np.stack([np.sin(thetas), 0 * thetas, np.cos(thetas)], axis=-1)
    albedo = np.mean(brdf.albedo(wo_albedo, samples=4096), axis=-1)
    row = {
        "file": path.name,
        "parameters": len(brdf.params()),
        "eval_ms": 1e3 * seconds,
        "finite": float(np.mean(finite)),
        "reciprocity": difference / scale if scale > 0 else 0.0,
        "max_albedo": float(np.nanmax(albedo)),
    }
    return row if oracle is None else {**row, **compare_opengl(oracle, brdf, wi, wo)}


def peer(folder: Path, name: str, wi: np.ndarray, wo: np.ndarray) -> dict:
    values, spec = PEERS[name]
    shader, native = read_brdf_explorer(folder / name, **values), parse(spec)
    a, b = shader.eval(wi, wo), np.broadcast_to(native.eval(wi, wo), (len(wi), 3))
    return {
        "file": name,
        "peer": spec,
        "max_relative_difference": float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))),
        "shader_ms": 1e3 * best_time(lambda: shader.eval(wi, wo)),
        "native_ms": 1e3 * best_time(lambda: native.eval(wi, wo)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="shared data folder")
    parser.add_argument("--pairs", type=int, default=100_000, help="direction pairs")
    args = parser.parse_args()
    folder = (args.data or io.data_path()) / "brdf_explorer"
    rng = np.random.default_rng(0)
    wi, wo = directions(args.pairs, rng), directions(args.pairs, rng)
    oracle = opengl()
    files = []
    print("| file | eval ms | finite | reciprocity | max albedo | OpenGL error | OpenGL NaN |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for path in sorted(folder.glob("*.brdf")):
        row = measure(path, wi, wo, oracle)
        files.append(row)
        print(f"| {row['file']} | {row['eval_ms']:.1f} | {row['finite']:.4f} | "
              f"{row['reciprocity']:.2e} | {row['max_albedo']:.3f} | "
              f"{row.get('opengl_error', math.nan):.1e} | "
              f"{row.get('opengl_nonfinite', math.nan):.3f} |", flush=True)  # fmt: skip
    peers = [peer(folder, name, wi, wo) for name in PEERS]
    for p in peers:
        print(f"{p['file']} vs {p['peer']}: max relative difference "
              f"{p['max_relative_difference']:.1e}, {p['shader_ms']:.1f} ms vs "
              f"{p['native_ms']:.1f} ms")  # fmt: skip
    record = {"pairs": args.pairs, "theta_o_deg": list(THETA_O), "opengl_pairs": OPENGL_PAIRS,
              "opengl": None if oracle is None else oracle[1].info["GL_RENDERER"],
              "files": files, "peers": peers}  # fmt: skip
    from _machine import write_results

    print(f"wrote {write_results(__file__, record, packages=('moderngl',))}")


if __name__ == "__main__":
    main()
