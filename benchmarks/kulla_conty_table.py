"""Generate ``src/brdfkit/data/kulla_conty_fresnel.npz``: the Fresnel attenuation of multiple
scattering on a GGX conductor, tabulated by Heitz et al.'s (2016) random walk.

For each GGX roughness α and view cosine μo = s² at Chebyshev nodes, one random walk
(:func:`brdfkit.brdf.random_walk.random_walk_albedo`, ``PATHS`` paths) carries, as channels,
the exact conductor Fresnel term of every (r, h) node: reflectivity r = F(1) and h, the
position of ln η between Gulbrandsen's (2014) bounds for that r
(:func:`brdfkit.brdf.kulla_conty.conductor_from_table_coordinates`). The table holds the ratio
estimator

    R(α, s, r, h) = (energy escaped after ≥ 2 reflections) / (paths escaped after ≥ 2 reflections),

the fraction of the multiple-scattering albedo 1 − E(μo) of the F = 1 microsurface that a
coloured Fresnel term lets out, on the same paths (so R ≤ 1 path by path, and R = 1 for F = 1).
:class:`brdfkit.brdf.KullaConty` interpolates it (a tensor Chebyshev interpolant in α, r, h,
then a series in s). Deterministic (fixed seeds); ~15 min on two busy cores.

``python benchmarks/kulla_conty_table.py`` (writes the .npz atomically; 33 KB).
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from brdfkit.brdf.kulla_conty import (
    FRESNEL_TABLE_AXES,
    chebyshev_nodes,
    conductor_from_table_coordinates,
)
from brdfkit.brdf.microfacet import FresnelTerm
from brdfkit.brdf.random_walk import random_walk_albedo
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.io import atomic_write

PATHS = 1 << 17
OUTPUT = Path(__file__).parents[1] / "src" / "brdfkit" / "data" / "kulla_conty_fresnel.npz"


def main() -> None:
    nodes = {name: chebyshev_nodes(n, lo, hi) for name, (n, lo, hi) in FRESNEL_TABLE_AXES.items()}
    r, h = np.meshgrid(nodes["r"], nodes["h"], indexing="ij")
    eta, k = conductor_from_table_coordinates(r.ravel(), h.ravel())
    fresnel = FresnelTerm("conductor", eta, k)  # nodes near r = 1 exceed the η domain of users
    shape = tuple(len(nodes[name]) for name in ("alpha", "s", "r", "h"))
    ratio = np.zeros(shape)
    escaped_later = np.zeros(shape[:2])
    start = time.perf_counter()
    for i, alpha in enumerate(nodes["alpha"]):
        for j, s in enumerate(nodes["s"]):
            wo = spherical_to_cartesian(np.arccos(s * s), np.array(0.0))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                walk = random_walk_albedo(
                    float(alpha), wo, fresnel=fresnel, paths=PATHS, seed=1000 * i + j
                )
            later = walk.albedo - walk.single
            ratio[i, j] = (later / max(walk.escaped_later, 1 / PATHS)).reshape(shape[2:])
            escaped_later[i, j] = walk.escaped_later
        print(f"α = {alpha:.3f} done ({time.perf_counter() - start:.0f} s)", flush=True)
    arrays = dict(
        ratio=ratio.astype(np.float32),
        escaped_later=escaped_later.astype(np.float32),
        paths=np.array(PATHS),
        **{f"{name}_nodes": value for name, value in nodes.items()},
    )
    atomic_write(OUTPUT, lambda tmp: np.savez_compressed(tmp, **arrays))
    print(f"wrote {OUTPUT} ({OUTPUT.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()
