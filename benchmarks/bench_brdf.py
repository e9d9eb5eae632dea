"""BRDF throughput of brdfkit (NumPy, JAX, compiled) against Mitsuba 3 ``llvm_ad_rgb``, side by side.

Workloads (the same inputs for every implementation, generated once per size):

- ``eval``: a GGX rough conductor (α = 0.2, gold's RGB complex index, separable Smith masking:
  Mitsuba's ``roughconductor``) evaluated on 10⁶ and 10⁷ direction pairs;
- ``sample+eval``: Lambertian + GGX (Mitsuba: ``blendbsdf`` of ``diffuse`` and
  ``roughconductor``) — importance-sample a direction, then evaluate the BRDF there, 10⁶ times;
- ``albedo``: the directional albedo of the GGX conductor at 90 angles × 10⁵ samples.

Every timing is the minimum over ``--repeats`` runs after a warm-up call; the first call's extra
time (tracing + JIT compilation) is reported separately. Mitsuba's ``eval`` includes the cosine
factor (f·cos θ); brdfkit's is f alone, so the cross-check divides it out.

Run ``benchmarks/setup.sh`` once, then ``python benchmarks/bench_brdf.py``; results go to
``benchmarks/results/brdf.json`` and a Markdown table on stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault(
    "XLA_FLAGS", "--xla_cpu_multi_thread_eigen=true intra_op_parallelism_threads=2"
)
os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")

import numpy as np  # noqa: E402

import brdfkit.accel as accel  # noqa: E402
from brdfkit.brdf import Lambertian, RoughConductor  # noqa: E402
from brdfkit.fresnel import conductor  # noqa: E402

ALPHA = 0.2
MATERIAL = "Au"
ALBEDO_ANGLES = 90
ALBEDO_SAMPLES = 100_000
DIFFUSE = 0.3


def timed(fn: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """``(first-call seconds, min over repeats of warm seconds)``."""
    start = time.perf_counter()
    fn()
    first = time.perf_counter() - start
    best = first if repeats == 0 else float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return first, best


def directions(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` uniform directions on the upper hemisphere, float32 ``(n, 3)``."""
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v.astype(np.float32)


def models(dtype: Any) -> tuple[RoughConductor, Any]:
    """The GGX conductor and Lambertian + GGX with parameters in ``dtype`` (float32 stays)."""
    eta, k = (np.asarray(v, dtype=dtype) for v in conductor(MATERIAL))
    ggx = RoughConductor(alpha=ALPHA, eta=eta, k=k, masking="smith_separable")
    return ggx, Lambertian(np.asarray(DIFFUSE, dtype=dtype)) + ggx


def albedo_directions() -> np.ndarray:
    theta = np.radians(np.linspace(0.0, 89.0, ALBEDO_ANGLES))
    return np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], -1).astype(np.float32)


# --------------------------------------------------------------------------- Mitsuba
class Mitsuba:
    """Mitsuba 3 ``llvm_ad_rgb`` versions of the three workloads."""

    def __init__(self) -> None:
        import drjit as dr
        import mitsuba as mi

        mi.set_variant("llvm_ad_rgb")
        self.dr, self.mi = dr, mi
        eta, k = conductor(MATERIAL)
        spec = {
            "type": "roughconductor",
            "distribution": "ggx",
            "alpha": ALPHA,
            "sample_visible": True,
            "eta": {"type": "rgb", "value": [float(v) for v in eta]},
            "k": {"type": "rgb", "value": [float(v) for v in k]},
        }
        self.ggx = mi.load_dict(spec)
        self.mix = mi.load_dict(
            {
                "type": "blendbsdf",
                "weight": 0.5,
                "a": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 2 * DIFFUSE}},
                "b": spec,
            }
        )
        self.ctx = mi.BSDFContext()
        self.version = f"mitsuba {mi.__version__}, drjit {dr.__version__}"

    def interaction(self, wo: np.ndarray) -> Any:
        si = self.dr.zeros(self.mi.SurfaceInteraction3f, len(wo))
        si.wi = self.mi.Vector3f(*(np.ascontiguousarray(wo[:, j]) for j in range(3)))
        return si

    def vectors(self, w: np.ndarray) -> Any:
        return self.mi.Vector3f(*(np.ascontiguousarray(w[:, j]) for j in range(3)))

    def eval_fn(self, wi: np.ndarray, wo: np.ndarray) -> tuple[Callable[[], Any], Any]:
        dr = self.dr
        si, wi_m = self.interaction(wo), self.vectors(wi)
        dr.eval(si, wi_m)
        dr.sync_thread()

        def run() -> Any:
            value = self.ggx.eval(self.ctx, si, wi_m)
            dr.eval(value)
            dr.sync_thread()
            return value

        return run, None

    def sample_eval_fn(self, wo: np.ndarray, u: np.ndarray) -> Callable[[], Any]:
        dr, mi = self.dr, self.mi
        si = self.interaction(wo)
        s1, s2 = mi.Float(np.ascontiguousarray(u[:, 2])), mi.Point2f(u[:, 0].copy(), u[:, 1].copy())
        dr.eval(si, s1, s2)
        dr.sync_thread()

        def run() -> Any:
            bs, weight = self.mix.sample(self.ctx, si, s1, s2)
            value = self.mix.eval(self.ctx, si, bs.wo)
            dr.eval(bs, weight, value)
            dr.sync_thread()
            return weight

        return run

    def albedo_fn(self, wo: np.ndarray, u: np.ndarray) -> Callable[[], np.ndarray]:
        dr, mi = self.dr, self.mi
        n = len(u)
        wo_rep = np.repeat(wo, n, axis=0)
        u_rep = np.tile(u, (len(wo), 1))
        si = self.interaction(wo_rep)
        s1, s2 = mi.Float(u_rep[:, 2].copy()), mi.Point2f(u_rep[:, 0].copy(), u_rep[:, 1].copy())
        dr.eval(si, s1, s2)
        dr.sync_thread()

        def run() -> np.ndarray:
            _, weight = self.ggx.sample(self.ctx, si, s1, s2)
            dr.eval(weight)
            dr.sync_thread()
            return np.asarray(weight).reshape(len(wo), n, 3).mean(axis=1)

        return run

    def jit_seconds(self, fn: Callable[[], Any]) -> float:
        """Dr.Jit's code generation + LLVM backend time of one call (0 on a disk-cache hit)."""
        dr = self.dr
        with dr.scoped_set_flag(dr.JitFlag.KernelHistory):
            fn()
            history = dr.kernel_history()
        return sum(
            (h.get("codegen_time", 0.0) + h.get("backend_time", 0.0)) / 1000 for h in history
        )


# --------------------------------------------------------------------------- runner
def run(sizes: list[int], repeats: int, with_mitsuba: bool) -> dict[str, Any]:
    rng = np.random.default_rng(1)
    ggx32, mix32 = models(np.float32)
    ggx64, _ = models(np.float64)
    compiled = accel.compile(ggx32)
    compiled_mix = accel.compile(mix32)
    mitsuba = Mitsuba() if with_mitsuba else None
    rows: list[dict[str, Any]] = []

    def add(workload: str, n: int, impl: str, first: float, best: float, **extra: Any) -> None:
        rows.append(
            {
                "workload": workload,
                "n": n,
                "impl": impl,
                "seconds": best,
                "per_second": n / best,
                "first_call_extra_seconds": max(first - best, 0.0),
                **extra,
            }
        )
        print(f"{workload:12s} {n:>10d} {impl:28s} {n / best:12.3e}/s", flush=True)

    for n in sizes:
        wi, wo = directions(rng, n), directions(rng, n)
        wi64, wo64 = wi.astype(np.float64), wo.astype(np.float64)
        reference = compiled.eval(wi, wo)  # the first call compiles
        first, best = timed(lambda: compiled.eval(wi, wo), repeats)
        add(
            "eval",
            n,
            "brdfkit accel f32 (numba)",
            first,
            best,
            compile_seconds=compiled.compile_seconds,
        )
        if n <= 1_000_000:
            first, best = timed(lambda: ggx32.eval(wi, wo), max(1, repeats // 2))
            add("eval", n, "brdfkit NumPy f32", first, best)
            first, best = timed(lambda: ggx64.eval(wi64, wo64), max(1, repeats // 2))
            add("eval", n, "brdfkit NumPy f64", first, best)
        first, best = timed(
            lambda: accel.eval_chunked(ggx32, wi, wo, workers=accel.threads()), max(1, repeats // 2)
        )
        add("eval", n, "brdfkit NumPy f32 chunked", first, best)
        check = {
            "max_rel_diff_numpy_f32": _rel(reference, accel.eval_chunked(ggx32, wi, wo)),
            "max_rel_diff_numpy_f64": _rel(reference, accel.eval_chunked(ggx64, wi64, wo64)),
        }
        if n <= 1_000_000:
            import jax
            import jax.numpy as jnp

            eval_jit = jax.jit(ggx32.eval)
            wi_j, wo_j = jnp.asarray(wi), jnp.asarray(wo)
            first, best = timed(lambda: eval_jit(wi_j, wo_j).block_until_ready(), repeats)
            add("eval", n, "brdfkit jax.jit f32", first, best)
        if mitsuba is not None:
            fn, _ = mitsuba.eval_fn(wi, wo)
            jit_s = mitsuba.jit_seconds(fn)
            first, best = timed(fn, repeats)
            value = np.asarray(fn()).reshape(n, 3)
            check["max_rel_diff_mitsuba"] = _rel(reference * wi[:, 2:3], value)
            add("eval", n, "Mitsuba 3 llvm_ad_rgb", first, best, jit_seconds=jit_s)
        rows[-1].update(check)
        del wi64, wo64

    n = 1_000_000
    wo = directions(rng, n)
    u = rng.random((n, 3), dtype=np.float32)

    def sample_eval() -> Any:
        s = compiled_mix.sample(wo, u)
        return compiled_mix.eval(s.wi, wo)

    start = time.perf_counter()
    compiled_mix.sample(wo[:1], u[:1])
    compiled_mix.eval(wo[:1], wo[:1])
    compile_s = time.perf_counter() - start
    first, best = timed(sample_eval, repeats)
    add("sample+eval", n, "brdfkit accel f32 (numba)", first, best, compile_seconds=compile_s)

    def sample_eval_numpy() -> Any:
        s = mix32.sample(wo, u)
        return mix32.eval(s.wi, wo)

    first, best = timed(sample_eval_numpy, max(1, repeats // 2))
    add("sample+eval", n, "brdfkit NumPy f32", first, best)
    if mitsuba is not None:
        fn = mitsuba.sample_eval_fn(wo, u)
        jit_s = mitsuba.jit_seconds(fn)
        first, best = timed(fn, repeats)
        add("sample+eval", n, "Mitsuba 3 llvm_ad_rgb", first, best, jit_seconds=jit_s)

    wo_a = albedo_directions()
    total = ALBEDO_ANGLES * ALBEDO_SAMPLES
    start = time.perf_counter()
    compiled.sample(wo_a[:1], u[:1])
    compile_s = time.perf_counter() - start
    first, best = timed(lambda: compiled.albedo(wo_a, samples=ALBEDO_SAMPLES), repeats)
    ours = compiled.albedo(wo_a, samples=ALBEDO_SAMPLES)
    add("albedo", total, "brdfkit accel f32 (numba)", first, best, compile_seconds=compile_s)
    first, best = timed(lambda: [ggx32.albedo(w, samples=ALBEDO_SAMPLES) for w in wo_a], 0)
    add("albedo", total, "brdfkit NumPy f32 (per angle)", first, best)
    if mitsuba is not None:
        u_a = rng.random((ALBEDO_SAMPLES, 3), dtype=np.float32)
        fn = mitsuba.albedo_fn(wo_a, u_a)
        jit_s = mitsuba.jit_seconds(fn)
        first, best = timed(fn, repeats)
        theirs = fn()
        add(
            "albedo",
            total,
            "Mitsuba 3 llvm_ad_rgb",
            first,
            best,
            jit_seconds=jit_s,
            max_abs_diff_albedo=float(np.max(np.abs(ours - theirs))),
        )
    return {"machine": machine(), "mitsuba": mitsuba.version if mitsuba else None, "rows": rows}


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a − b| relative to max(|b|, 1e-3 · max|b|) (small values compare absolutely)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    scale = np.maximum(np.abs(b), 1e-3 * np.max(np.abs(b)))
    return float(np.max(np.abs(a - b) / scale))


def machine() -> dict[str, Any]:
    model = next(
        (
            line.split(":", 1)[1].strip()
            for line in subprocess.run(
                ["lscpu"], capture_output=True, text=True
            ).stdout.splitlines()
            if line.startswith("Model name")
        ),
        platform.processor(),
    )
    import numba

    return {
        "cpu": model,
        "cores": len(os.sched_getaffinity(0)),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "load_average_at_start": os.getloadavg(),
    }


def table(result: dict[str, Any]) -> str:
    """A Markdown table: throughput and the ratio to Mitsuba of the same workload and size."""
    rows = result["rows"]
    peer = {
        (r["workload"], r["n"]): r["per_second"] for r in rows if r["impl"].startswith("Mitsuba")
    }
    lines = [
        "| workload | n | implementation | evaluations/s | ratio to Mitsuba | first-call extra (s) |",
        "|---|---:|---|---:|---:|---:|",
    ]
    for r in rows:
        ratio = r["per_second"] / peer[(r["workload"], r["n"])] if peer else float("nan")
        lines.append(
            f"| {r['workload']} | {r['n']:.0e} | {r['impl']} | {r['per_second']:.3g} | "
            f"{ratio:.2f} | {r['first_call_extra_seconds']:.3f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1e6, 1e7])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-mitsuba", action="store_true")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "brdf.json")
    args = parser.parse_args()
    result = run([int(s) for s in args.sizes], args.repeats, not args.no_mitsuba)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1))
    print()
    print(table(result))


if __name__ == "__main__":
    main()
