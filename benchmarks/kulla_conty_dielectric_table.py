"""Generate ``src/brdfkit/data/kulla_conty_dielectric.npz``: how a rough GGX dielectric splits
its multiply scattered light between reflection and transmission, tabulated by Heitz et al.'s
(2016) dielectric random walk.

For each roughness α, relative index η > 1 and view cosine μ = s² at Chebyshev nodes
(:data:`brdfkit.brdf.kulla_conty_dielectric.SPLIT_TABLE_AXES`), two walks of 2¹⁷ paths
(:func:`brdfkit.brdf.kulla_conty_dielectric.split_node`), from outside (relative index η) and
from inside (1/η), give the albedo of the paths scattered more than once that leave on the
side they came from (reflected) and on the other (transmitted).
:class:`brdfkit.brdf.KullaContyDielectric` (``split="random_walk"``) interpolates both
(tensor Chebyshev in α and ln η) and splits its compensated energy by their ratio.
Deterministic (fixed seeds); ~3 min on two busy cores.

``python benchmarks/kulla_conty_dielectric_table.py`` (writes the .npz atomically; ~10 KB).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from brdfkit.brdf.kulla_conty import chebyshev_nodes
from brdfkit.brdf.kulla_conty_dielectric import (
    SPLIT_TABLE_AXES,
    SPLIT_TABLE_PATHS,
    split_node,
)
from brdfkit.io import atomic_write

OUTPUT = Path(__file__).parents[1] / "src" / "brdfkit" / "data" / "kulla_conty_dielectric.npz"


def main() -> None:
    nodes = {name: chebyshev_nodes(*axis) for name, axis in SPLIT_TABLE_AXES.items()}
    shape = (*(len(nodes[name]) for name in ("alpha", "log_eta", "s")), 2, 2)
    multiple = np.zeros(shape)
    start = time.process_time()
    for i, alpha in enumerate(nodes["alpha"]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                multiple[i, j, k] = split_node(i, j, k)
        print(f"α = {alpha:.3f} done ({time.process_time() - start:.0f} s CPU)", flush=True)
    arrays = dict(
        multiple=multiple.astype(np.float32),
        paths=np.array(SPLIT_TABLE_PATHS),
        **{f"{name}_nodes": value for name, value in nodes.items()},
    )
    atomic_write(OUTPUT, lambda tmp: np.savez_compressed(tmp, **arrays))
    print(f"wrote {OUTPUT} ({OUTPUT.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()
