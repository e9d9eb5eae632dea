"""BRDF throughput of brdfkit (NumPy, JAX, compiled) and Mitsuba 3 ``llvm_ad_rgb``, side by side.

Workloads (the same inputs for every implementation, generated once per size):

- ``eval``: a GGX rough conductor (α = 0.2, gold's RGB complex index, separable Smith masking:
  Mitsuba's ``roughconductor``) evaluated on 10⁶ and 10⁷ direction pairs; brdfkit on ``(n, 3)``
  rows and, as Mitsuba reads and writes them, component by component (``np.asfortranarray``,
  made before the timing as Mitsuba's ``Vector3f`` is);
- ``sample+eval``: Lambertian + GGX (Mitsuba: ``blendbsdf`` of ``diffuse`` and
  ``roughconductor``) — importance-sample a direction, then evaluate the BRDF there, 10⁶ times;
- ``albedo``: the directional albedo of the GGX conductor at 90 angles × 10⁵ samples.

Every timing is the minimum over ``--repeats`` runs after a warm-up call; the first call's extra
time (tracing + JIT compilation) is reported separately. The ``eval`` head-to-head also records
the minimum CPU seconds of the process per call (``cpu_seconds``, every thread's; the table's
"CPU-time ratio"): on a machine shared with other work, wall time also counts the waits for a
core. It is approximate too: Dr.Jit's workers spin on after a call (:data:`PAUSE`), into the next
timed call when the rest is short, and a thread still running when the clock is read has its
last scheduler tick uncounted. Mitsuba's ``eval`` includes the cosine factor (f·cos θ);
brdfkit's is f alone, so the cross-check divides it out.

Run ``benchmarks/setup.sh`` once, then ``python benchmarks/bench_brdf.py``; results go to
``benchmarks/results/brdf.json`` and a Markdown table on stdout.
"""

from __future__ import annotations

import argparse
import dataclasses
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

import numpy as np

from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.compiled import DEFAULT_CHUNK, compile, eval_chunked, threads
from brdfkit.fresnel import conductor
from brdfkit.interop import to_mitsuba_dict

ALPHA = 0.2
MATERIAL = "Au"
ALBEDO_ANGLES = 90
ALBEDO_SAMPLES = 100_000
DIFFUSE = 0.3


PAUSE = 0.03
"""Seconds of rest before every timed call. Dr.Jit's worker threads spin after each kernel
(measured: 22 ms of CPU in the 50 ms after a Mitsuba call, 0.1 ms after brdfkit's), which on
a 2-core machine slows whatever runs next; the rest gives every call idle cores to start on."""


def timed(fn: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """``(first-call seconds, min over repeats of warm seconds)``."""
    start = time.perf_counter()
    fn()
    first = time.perf_counter() - start
    best = first if repeats == 0 else float("inf")
    for _ in range(repeats):
        time.sleep(PAUSE)
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return first, best


def timed_interleaved(
    fns: list[Callable[[], Any]], repeats: int
) -> list[tuple[float, float, float]]:
    """:func:`timed` for several functions, alternating them in every repeat, so that a burst
    of load from other processes on a busy machine hits all of them alike; also the minimum
    CPU seconds of the process (every thread's) per call, which waiting for a core that other
    processes hold does not inflate as it does wall time."""
    first = []
    for fn in fns:
        start = time.perf_counter()
        fn()
        first.append(time.perf_counter() - start)
    best = [float("inf")] * len(fns)
    cpu = [float("inf")] * len(fns)
    for _ in range(repeats):
        for k, fn in enumerate(fns):
            time.sleep(PAUSE)
            start, start_cpu = time.perf_counter(), time.process_time()
            fn()
            cpu[k] = min(cpu[k], time.process_time() - start_cpu)
            best[k] = min(best[k], time.perf_counter() - start)
    return list(zip(first, best, cpu, strict=True))


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
        ggx, mix = models(np.float64)
        self.ggx = mi.load_dict(to_mitsuba_dict(ggx))
        self.mix = mi.load_dict(to_mitsuba_dict(mix))
        self.ctx = mi.BSDFContext()
        self.version = f"mitsuba {mi.__version__}, drjit {dr.__version__}"

    def interaction(self, wo: np.ndarray) -> Any:
        si = self.dr.zeros(self.mi.SurfaceInteraction3f, len(wo))
        si.wi = self.mi.Vector3f(*(np.ascontiguousarray(wo[:, j]) for j in range(3)))
        return si

    def vectors(self, w: np.ndarray) -> Any:
        return self.mi.Vector3f(*(np.ascontiguousarray(w[:, j]) for j in range(3)))

    def eval_fn(self, wi: np.ndarray, wo: np.ndarray) -> Callable[[], Any]:
        dr = self.dr
        si, wi_m = self.interaction(wo), self.vectors(wi)
        dr.eval(si, wi_m)
        dr.sync_thread()

        def run() -> Any:
            value = self.ggx.eval(self.ctx, si, wi_m)
            dr.eval(value)
            dr.sync_thread()
            return value

        return run

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
            return np.asarray(weight).T.reshape(len(wo), n, 3).mean(axis=1)

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
class Runner:
    """Runs the workloads and collects one row per (workload, size, implementation)."""

    def __init__(self, repeats: int, with_mitsuba: bool) -> None:
        self.repeats = repeats
        self.rng = np.random.default_rng(1)
        self.ggx32, self.mix32 = models(np.float32)
        self.ggx64, _ = models(np.float64)
        self.compiled = compile(self.ggx32)
        self.compiled_mix = compile(self.mix32)
        self.mitsuba = Mitsuba() if with_mitsuba else None
        self.rows: list[dict[str, Any]] = []

    def add(
        self,
        workload: str,
        n: int,
        impl: str,
        fn: Callable[[], Any] | tuple[float, float],
        repeats: int = 0,
        **extra: Any,
    ) -> None:
        """Time ``fn`` (or take its ``(first, best)`` timing) and record a row."""
        first, best = fn if isinstance(fn, tuple) else timed(fn, repeats)
        self.rows.append(
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
        print(f"{workload:12s} {n:>10d} {impl:34s} {n / best:12.3e}/s", flush=True)

    def eval(self, n: int) -> None:
        wi, wo = directions(self.rng, n), directions(self.rng, n)
        # Renormalised in float64: float32 unit vectors are off by ~1e-7, beyond the ±4 ulp
        # slack the float64 Fresnel code allows for cosines.
        wi64, wo64 = (
            v / np.linalg.norm(v, axis=-1, keepdims=True)
            for v in (wi.astype(np.float64), wo.astype(np.float64))
        )
        ggx32, ggx64, compiled = self.ggx32, self.ggx64, self.compiled
        check: dict[str, float] = {}
        reference = compiled.eval(wi, wo)  # the first call compiles
        wi_c, wo_c = np.asfortranarray(wi), np.asfortranarray(wo)
        check["max_rel_diff_component_major"] = _rel(compiled.eval(wi_c, wo_c), reference)
        out = np.empty_like(reference)
        r, slow = self.repeats, max(1, self.repeats // 2)
        workers = threads()
        # The head-to-head: brdfkit accel, brdfkit's chunked NumPy path and Mitsuba, interleaved.
        fns: dict[str, tuple[Callable[[], Any], dict[str, Any]]] = {
            "brdfkit accel f32": (
                lambda: compiled.eval(wi, wo),
                {"compile_seconds": compiled.compile_seconds},
            ),
            "brdfkit accel f32, out= reused": (lambda: compiled.eval(wi, wo, out=out), {}),
            # Mitsuba's layout: the directions component by component (its Vector3f is three
            # arrays, filled before its timing), and so the result (its Color3f is three too)
            "brdfkit accel f32, component-major": (lambda: compiled.eval(wi_c, wo_c), {}),
            f"brdfkit NumPy f32 chunked ×{workers}": (
                lambda: eval_chunked(ggx32, wi, wo, workers=workers),
                {"chunk": DEFAULT_CHUNK},
            ),
        }
        if self.mitsuba is not None:
            mitsuba_fn = self.mitsuba.eval_fn(wi, wo)
            jit_s = self.mitsuba.jit_seconds(mitsuba_fn)
            fns["Mitsuba 3 llvm_ad_rgb"] = (mitsuba_fn, {"jit_seconds": jit_s})
            value = np.asarray(mitsuba_fn()).T  # Color3f converts as (3, n)
            check["max_rel_diff_mitsuba_f_cos"] = _rel(reference * wi[:, 2:3], value)
        timings = timed_interleaved([fn for fn, _ in fns.values()], r)
        for (impl, (_, extra)), (first, best, cpu) in zip(fns.items(), timings, strict=True):
            self.add("eval", n, impl, (first, best), cpu_seconds=cpu, **extra)
        if n <= 1_000_000:  # one call allocates ~200 bytes per pair: 2 GB at 1e7
            # Another parameter set of the same structure: no trace, no compile (its first
            # call's extra time is the binding of its values only).
            other = compile(dataclasses.replace(ggx32, alpha=np.float32(0.35)))
            self.add(
                "eval",
                n,
                "brdfkit accel f32, new parameters",
                lambda: other.eval(wi, wo),
                r,
            )
            self.add("eval", n, "brdfkit NumPy f32", lambda: ggx32.eval(wi, wo), slow)
            self.add("eval", n, "brdfkit NumPy f64", lambda: ggx64.eval(wi64, wo64), slow)
        if workers > 1:  # what the threads add (NumPy holds the GIL between its loops)
            self.add(
                "eval",
                n,
                "brdfkit NumPy f32 chunked ×1",
                lambda: eval_chunked(ggx32, wi, wo),
                slow,
            )
        check["max_rel_diff_numpy_f32"] = _rel(reference, eval_chunked(ggx32, wi, wo))
        check["max_rel_diff_numpy_f64"] = _rel(reference, eval_chunked(ggx64, wi64, wo64))
        if n <= 1_000_000:
            import jax
            import jax.numpy as jnp

            eval_jit = jax.jit(ggx32.eval)
            wi_j, wo_j = jnp.asarray(wi), jnp.asarray(wo)
            self.add(
                "eval",
                n,
                "brdfkit jax.jit f32",
                lambda: eval_jit(wi_j, wo_j).block_until_ready(),
                r,
            )
        self.rows[-1].update(check)

    def sample_eval(self, n: int) -> None:
        wo = directions(self.rng, n)
        u = self.rng.random((n, 3), dtype=np.float32)
        compiled, mix32 = self.compiled_mix, self.mix32

        def ours() -> Any:
            s = compiled.sample(wo, u)
            return compiled.eval(s.wi, wo)

        def numpy_path() -> Any:
            s = mix32.sample(wo, u)
            return mix32.eval(s.wi, wo)

        ours()
        self.add(
            "sample+eval",
            n,
            "brdfkit accel f32",
            ours,
            self.repeats,
            compile_seconds=compiled.compile_seconds,
        )
        self.add("sample+eval", n, "brdfkit NumPy f32", numpy_path, max(1, self.repeats // 2))
        if self.mitsuba is not None:
            fn = self.mitsuba.sample_eval_fn(wo, u)
            jit_s = self.mitsuba.jit_seconds(fn)
            self.add("sample+eval", n, "Mitsuba 3 llvm_ad_rgb", fn, self.repeats, jit_seconds=jit_s)

    def albedo(self) -> None:
        wo = albedo_directions()
        total = ALBEDO_ANGLES * ALBEDO_SAMPLES
        compiled, ggx32 = self.compiled, self.ggx32
        ours = compiled.albedo(wo, samples=ALBEDO_SAMPLES)
        self.add(
            "albedo",
            total,
            "brdfkit accel f32",
            lambda: compiled.albedo(wo, samples=ALBEDO_SAMPLES),
            self.repeats,
        )
        self.add(
            "albedo",
            total,
            "brdfkit NumPy f32 (per angle)",
            lambda: [ggx32.albedo(w, samples=ALBEDO_SAMPLES) for w in wo],
            0,
        )
        if self.mitsuba is not None:
            u = self.rng.random((ALBEDO_SAMPLES, 3), dtype=np.float32)
            fn = self.mitsuba.albedo_fn(wo, u)
            jit_s = self.mitsuba.jit_seconds(fn)
            self.add(
                "albedo",
                total,
                "Mitsuba 3 llvm_ad_rgb",
                fn,
                self.repeats,
                jit_seconds=jit_s,
                max_abs_diff_albedo=float(np.max(np.abs(ours - fn()))),
            )


def run(sizes: list[int], repeats: int, with_mitsuba: bool) -> dict[str, Any]:
    about = machine()  # before the run: its load average is the other processes'
    runner = Runner(repeats, with_mitsuba)
    for n in sizes:
        runner.eval(n)
    runner.sample_eval(1_000_000)
    runner.albedo()
    return {
        "host": {**about, "load_average_at_end": os.getloadavg()},
        "mitsuba": runner.mitsuba.version if runner.mitsuba else None,
        "rows": runner.rows,
    }


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
    peer_cpu = {
        (r["workload"], r["n"]): r["cpu_seconds"]
        for r in rows
        if r["impl"].startswith("Mitsuba") and "cpu_seconds" in r
    }
    lines = [
        "| workload | n | implementation | evals/s | ratio to Mitsuba | CPU-time ratio "
        "| first call extra (s) |",
        "|---|---:|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        key = (r["workload"], r["n"])
        ratio = r["per_second"] / peer[key] if peer else float("nan")
        cpu_ratio = (
            peer_cpu[key] / r["cpu_seconds"] if key in peer_cpu and "cpu_seconds" in r else None
        )
        cpu_text = "" if cpu_ratio is None else f"{cpu_ratio:.3g}"
        lines.append(
            f"| {r['workload']} | {r['n']:.0e} | {r['impl']} | {r['per_second']:.3g} | "
            f"{ratio:.3g} | {cpu_text} | {r['first_call_extra_seconds']:.3f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1e6, 1e7])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-mitsuba", action="store_true")
    parser.add_argument("--out", type=Path, help="default: benchmarks/results/brdf.json")
    args = parser.parse_args()
    result = run([int(s) for s in args.sizes], args.repeats, not args.no_mitsuba)
    from _machine import header, results_path

    out = args.out or results_path(__file__)
    record = {**header(__file__, packages=("jax", "jaxlib", "mitsuba", "drjit")), **result}
    out.write_text(json.dumps(record, indent=1) + "\n")
    print()
    print(table(result))


if __name__ == "__main__":
    main()
