"""Generate ``src/brdfkit/data/kulla_conty_fresnel.npz``: the Fresnel attenuation of multiple
scattering on a GGX conductor, tabulated by Heitz et al.'s (2016) random walk.

For each GGX roughness α and view cosine μo = s² at Chebyshev nodes, one random walk
(:func:`brdfkit.brdf.kulla_conty.fresnel_ratio_node`, 2¹⁷ paths) carries, as channels,
the exact conductor Fresnel term of every (r, h) node: reflectivity r = F(1) and h, the
position of ln η between Gulbrandsen's (2014) bounds for that r
(:func:`brdfkit.brdf.kulla_conty.conductor_from_table_coordinates`). The table holds the ratio
estimator

    R(α, s, r, h) = (energy escaped after ≥ 2 reflections) / (paths escaped after ≥ 2 reflections),

the fraction of the multiple-scattering albedo 1 − E(μo) of the F = 1 microsurface that a
coloured Fresnel term lets out, on the same paths (so R ≤ 1 path by path, and R = 1 for F = 1).
:class:`brdfkit.brdf.KullaConty` interpolates it (a tensor Chebyshev interpolant in α, r, h,
then a series in s). Deterministic (fixed seeds); ~5 min on two busy cores.

``python benchmarks/kulla_conty_table.py`` (writes the .npz atomically; 32 KB).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from brdfkit.brdf.kulla_conty import (
    FRESNEL_TABLE_AXES,
    FRESNEL_TABLE_PATHS,
    chebyshev_nodes,
    fresnel_ratio_node,
)
from brdfkit.io import atomic_write

OUTPUT = Path(__file__).parents[1] / "src" / "brdfkit" / "data" / "kulla_conty_fresnel.npz"


def main() -> None:
    nodes = {name: chebyshev_nodes(*axis) for name, axis in FRESNEL_TABLE_AXES.items()}
    shape = tuple(len(nodes[name]) for name in ("alpha", "s", "r", "h"))
    ratio = np.zeros(shape)
    escaped_later = np.zeros(shape[:2])
    start = time.perf_counter()
    for i, alpha in enumerate(nodes["alpha"]):
        for j in range(shape[1]):
            ratio[i, j], escaped_later[i, j] = fresnel_ratio_node(i, j)
        print(f"α = {alpha:.3f} done ({time.perf_counter() - start:.0f} s)", flush=True)
    arrays = dict(
        ratio=ratio.astype(np.float32),
        escaped_later=escaped_later.astype(np.float32),
        paths=np.array(FRESNEL_TABLE_PATHS),
        **{f"{name}_nodes": value for name, value in nodes.items()},
    )
    atomic_write(OUTPUT, lambda tmp: np.savez_compressed(tmp, **arrays))
    print(f"wrote {OUTPUT} ({OUTPUT.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()
