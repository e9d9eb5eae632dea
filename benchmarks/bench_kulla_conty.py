"""What Kulla–Conty energy compensation costs over the plain GGX conductor it extends.

Workloads: ``eval`` of ``kulla_conty(alpha=0.5, material='Au')`` and of its single-scattering
lobe ``rough_conductor(alpha=0.5, material='Au')`` on 10⁶ float32 direction pairs, on the NumPy
path and compiled (:func:`brdfkit.compiled.compile`), interleaved (A, B, A, B, …) and reported
as ratios; and the one-time cost of a roughness's E(μ) table (:func:`albedo_table`, first
call, uncached). The machine is shared: read the ratios, not the seconds.

``python benchmarks/bench_kulla_conty.py``; results go to ``benchmarks/results/kulla_conty.json``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from brdfkit.brdf import KullaConty, RoughConductor
from brdfkit.brdf.kulla_conty import albedo_table
from brdfkit.compiled import compile
from brdfkit.sampling import square_to_uniform_hemisphere

PAIRS = 1_000_000
REPEATS = 5


def best_of(fn, repeats: int = REPEATS) -> float:
    """Minimum wall time over ``repeats`` calls (after one warm-up)."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    rng = np.random.default_rng(0)
    wi = square_to_uniform_hemisphere(rng.random((PAIRS, 2))).astype(np.float32)
    wo = square_to_uniform_hemisphere(rng.random((PAIRS, 2))).astype(np.float32)
    compensated = KullaConty(alpha=0.5, material="Au")
    single = RoughConductor(alpha=0.5, material="Au")
    results = {}
    for path, make in (("numpy", lambda m: m), ("compiled", compile)):
        kc, ss = make(compensated), make(single)
        kc_times, ss_times = [], []
        for _ in range(3):  # interleaved
            kc_times.append(best_of(lambda kc=kc: kc.eval(wi, wo)))
            ss_times.append(best_of(lambda ss=ss: ss.eval(wi, wo)))
        results[path] = {
            "kulla_conty_s": min(kc_times),
            "rough_conductor_s": min(ss_times),
            "ratio": min(kc_times) / min(ss_times),
        }
    albedo_table.cache_clear()
    start = time.perf_counter()
    albedo_table(0.37)
    results["table_seconds"] = time.perf_counter() - start
    from _machine import header

    path = Path(__file__).parent / "results" / "kulla_conty.json"
    path.write_text(json.dumps({**header(__file__), **results}, indent=2) + "\n")
    print("| path | kulla_conty / rough_conductor eval time (10⁶ float32 pairs) |")
    print("|---|---|")
    for name in ("numpy", "compiled"):
        print(f"| {name} | {results[name]['ratio']:.2f} |")
    print(f"E(μ) table for one α: {results['table_seconds']:.2f} s")


if __name__ == "__main__":
    main()
