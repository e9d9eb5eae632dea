"""ns per environment-map sample's texel search in the compiled render kernel.

The tile kernel's map sample finds, per variate pair, the row of the marginal CDF and the
column of that row's conditional CDF. The peer is a fixed-step bisection run in lock step over
a block of 256 variates (``sampling._find_interval``'s ~10 + ~11 steps on a 1k map: the
``lockstep`` baseline below, what the kernel did before guide tables); the kernel scans from
guide tables (Chen & Asau 1974; the ``sample_texels`` of
:func:`brdfkit.light.environment.compiled_lookups`). Both run here on the same variates in
blocks of 256, alternating, best of ``--repeats``; the texels they find are checked equal. Run
single-threaded (the kernels are serial anyway):

    NUMBA_NUM_THREADS=1 python benchmarks/bench_env_sampling.py [--data ../shared/data]
        [--map royal_esplanade_1k.hdr studio_small_03_1k.hdr] [--samples 1048576] [--repeats 15]

Prints ns per sample of each and their ratio, per map; writes them to
``benchmarks/results/env_sampling.json``.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numba
import numpy as np

from brdfkit.compiled import kernel_tools
from brdfkit.light import EnvironmentMap
from brdfkit.light.environment import compiled_lookups
from brdfkit.render.compiled_shading import BLOCK

select = kernel_tools.select()


@numba.njit(nogil=True, error_model="numpy")
def _find_intervals(cdf, base, u, count, steps, nb, out):  # the lock-step baseline
    for j in range(nb):
        out[j] = 0
    hi = np.empty(nb, np.int64)
    for j in range(nb):
        hi[j] = count
    for _ in range(steps):
        for j in range(nb):
            mid = (out[j] + hi[j]) >> 1
            right = cdf[base[j] + mid] <= u[j]
            out[j], hi[j] = select(right, mid, out[j]), select(right, hi[j], mid)


@numba.njit(nogil=True, error_model="numpy")
def _lockstep(a, b, marginal, conditional, height, width, row_steps, col_steps, n, rows, cols):
    base = np.empty(BLOCK, np.int64)
    r, c = np.empty(BLOCK, np.int64), np.empty(BLOCK, np.int64)
    for start in range(0, n, BLOCK):
        nb = min(BLOCK, n - start)
        for j in range(nb):
            base[j] = 0
        _find_intervals(marginal, base, b[start:], height, row_steps, nb, r)
        for j in range(nb):
            base[j] = r[j] * (width + 1)
        _find_intervals(conditional, base, a[start:], width, col_steps, nb, c)
        for j in range(nb):
            rows[start + j], cols[start + j] = r[j], c[j]


def _guided(map_samples):
    @numba.njit(nogil=True, error_model="numpy")
    def run(a, b, marginal, conditional, row_guide, col_guide, height, width, n, rows, cols):
        base = np.empty(BLOCK, np.int64)
        r, c = np.empty(BLOCK, np.int64), np.empty(BLOCK, np.int64)
        for start in range(0, n, BLOCK):
            nb = min(BLOCK, n - start)
            map_samples(a[start:], b[start:], marginal, conditional, row_guide, col_guide,
                        height, width, nb, r, c, base)  # fmt: skip
            for j in range(nb):
                rows[start + j], cols[start + j] = r[j], c[j]

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(Path(__file__).parents[2] / "shared" / "data"))
    parser.add_argument(
        "--map", nargs="+", default=["royal_esplanade_1k.hdr", "studio_small_03_1k.hdr"]
    )
    parser.add_argument("--samples", type=int, default=2**20)
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    maps = [measure(args, name) for name in args.map]
    from _machine import write_results

    write_results(
        __file__,
        {"samples": args.samples, "repeats": args.repeats,
         "numba_threads": numba.get_num_threads(), "maps": maps},
    )  # fmt: skip


def measure(args: argparse.Namespace, map_name: str) -> dict:
    """ns per sample of the lock-step bisection and of the guide tables on one map."""
    env = EnvironmentMap.from_file(Path(args.data) / "envmaps" / "polyhaven" / map_name)
    d = env._distribution
    height, width = d.shape
    marginal, conditional = d._marginal, d._conditional
    rng = np.random.default_rng(0)
    below_one = 1 - np.finfo(np.float64).eps / 2
    # the kernel's variates: float32 uniforms, in float64 clamped below 1
    a, b = (np.minimum(rng.random(args.samples, np.float32).astype(np.float64), below_one)
            for _ in range(2))  # fmt: skip
    n = args.samples
    steps = (max(1, math.ceil(math.log2(height))) + 1, max(1, math.ceil(math.log2(width))) + 1)
    lookups = compiled_lookups(np.float32, kernel_tools)
    guides = lookups.tables(env)[-2:]
    guided = _guided(lookups.sample_texels)
    out = {name: (np.empty(n, np.int64), np.empty(n, np.int64)) for name in ("lockstep", "guide")}
    calls = {
        "lockstep": lambda: _lockstep(
            a, b, marginal, conditional, height, width, *steps, n, *out["lockstep"]
        ),
        "guide": lambda: guided(
            a, b, marginal, conditional, *guides, height, width, n, *out["guide"]
        ),
    }
    best = {name: math.inf for name in calls}
    for call in calls.values():
        call()  # compile
    for _ in range(args.repeats):
        for name, call in calls.items():
            start = time.perf_counter()
            call()
            best[name] = min(best[name], time.perf_counter() - start)
    for x, y in zip(out["lockstep"], out["guide"], strict=True):
        np.testing.assert_array_equal(x, y)
    print(f"{map_name} {height}x{width}, {n} samples, numba threads {numba.get_num_threads()}")
    for method, seconds in best.items():
        print(f"{method:9s} {seconds / n * 1e9:7.2f} ns/sample (best of {args.repeats})")
    print(f"ratio lockstep/guide {best['lockstep'] / best['guide']:.2f}")
    return {
        "map": map_name, "height": height, "width": width,
        "ns_per_sample": {method: seconds / n * 1e9 for method, seconds in best.items()},
        "ratio": best["lockstep"] / best["guide"],
    }  # fmt: skip


if __name__ == "__main__":
    main()
