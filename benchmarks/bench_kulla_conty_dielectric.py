"""Cost of Kulla–Conty compensation on a rough dielectric: ``eval`` of
:class:`brdfkit.brdf.KullaContyDielectric` against its single-scattering lobe
(:class:`brdfkit.brdf.RoughDielectric`, GGX, height-correlated Smith), 2·10⁵ direction pairs
on the sphere, NumPy, interleaved repeats, CPU seconds (process_time; the machine may be
shared), and the one-off construction cost of a new (α, η) (E(μ) by quadrature, cached).

``python benchmarks/bench_kulla_conty_dielectric.py``; results go to
``benchmarks/results/kulla_conty_dielectric.json``.
"""

from __future__ import annotations

import time

import numpy as np

from brdfkit.brdf import KullaContyDielectric, RoughDielectric
from brdfkit.sampling import square_to_uniform_sphere

PAIRS = 200_000
REPEATS = 7


def main() -> None:
    rng = np.random.default_rng(0)
    wi = square_to_uniform_sphere(rng.random((PAIRS, 2)))
    wo = square_to_uniform_sphere(rng.random((PAIRS, 2)))
    start = time.process_time()
    compensated = KullaContyDielectric(alpha=0.5, eta=1.5)
    construction = time.process_time() - start
    single = RoughDielectric(alpha=0.5, eta=1.5, masking="smith_correlated")
    times = {"kulla_conty_dielectric": [], "rough_dielectric": []}
    for _ in range(REPEATS):
        for name, model in (("kulla_conty_dielectric", compensated), ("rough_dielectric", single)):
            start = time.process_time()
            model.eval(wi, wo)
            times[name].append(time.process_time() - start)
    best = {name: min(values) for name, values in times.items()}
    print(f"construction of a new (α, η): {construction:.2f} s CPU")
    for name, value in best.items():
        print(f"{name}: {value * 1e3:.1f} ms CPU per {PAIRS} pairs (best of {REPEATS})")
    print(f"ratio: {best['kulla_conty_dielectric'] / best['rough_dielectric']:.2f}")
    from _machine import write_results

    write_results(
        __file__,
        {"pairs": PAIRS, "repeats": REPEATS, "construction_cpu_seconds": construction,
         "cpu_seconds": best,
         "ratio": best["kulla_conty_dielectric"] / best["rough_dielectric"]},
    )  # fmt: skip


if __name__ == "__main__":
    main()
