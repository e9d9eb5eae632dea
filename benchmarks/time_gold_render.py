"""Single-thread time of one compiled 256² gold render at 16 spp: the kernel.

``render_sphere`` of ``bench_render.py``'s gold scene (GGX α = 0.2 gold under
``royal_esplanade_1k``), ``compiled=True``, on one thread (``BRDFKIT_THREADS=1``); the first
call builds (or loads) the kernels and prepares the tiles, the timed calls after it reuse
that set-up (``render_sphere`` keeps it), so they time the tile kernel and its uniforms. Only
public API: the same script times any checkout (``PYTHONPATH``), so that runs of two
checkouts can alternate. Prints the best wall and CPU seconds of ``--repeats`` calls (the
same seed each: the same image) and, with ``--save``, writes that image (``.npy``).

    BRDFKIT_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/time_gold_render.py
        [--data ../shared/data] [--repeats 5] [--save image.npy]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np

from brdfkit.interop import mitsuba as ms
from brdfkit.io import atomic_write
from brdfkit.light import EnvironmentMap
from brdfkit.render import render_sphere


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BRDFKIT_DATA", "../shared/data"))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--save", help="write the image here (.npy)")
    args = parser.parse_args()
    scene = next(s for s in ms.benchmark_scenes(tabulated=False) if s.name == "gold")
    env = EnvironmentMap.from_file(Path(args.data) / "envmaps" / "polyhaven" / scene.envmap)

    def render() -> np.ndarray:
        return render_sphere(scene.brdf, env, 256, samples=args.samples, seed=7, compiled=True)

    image = render()  # build, prepare
    wall = cpu = math.inf
    for _ in range(args.repeats):
        w, c = time.perf_counter(), time.process_time()
        again = render()
        wall, cpu = min(wall, time.perf_counter() - w), min(cpu, time.process_time() - c)
        np.testing.assert_array_equal(again, image)
    print(f"wall {wall:.4f} s  cpu {cpu:.4f} s  (best of {args.repeats})")
    if args.save:
        atomic_write(args.save, lambda tmp: np.save(tmp, image))


if __name__ == "__main__":
    main()
