"""Photometric stereo at DiLiGenT size: 96 images of 612 x 512 pixels.

Renders the real DiLiGenT bear ground-truth normals (40 670 mask pixels; Lambertian +
Blinn-Phong, attached and cast shadows, noise; the real DiLiGenT images are not available here)
and times every calibrated method of ``brdfkit ps`` (the registries of
:mod:`brdfkit.vision.photometric_stereo`, :mod:`~brdfkit.vision.bivariate_stereo`,
:mod:`~brdfkit.vision.consensus` and :mod:`~brdfkit.vision.inverse_rendering_stereo`), least
squares on every pixel of the stack and on the object mask, the others on the mask. The target
is < 2 s per method on 2 cores; inverse rendering, which renders the stack some hundred times
and marches its cast shadows, is to take a minute at most. Prints one JSON
record per line (and writes them all to ``benchmarks/results/photometric_stereo.json``):
method, pixels, wall seconds (best of ``--repeat``), the CPU seconds of that run (all threads;
more than the wall time when BLAS runs in parallel), iterations, the mean / median angular
error in degrees and the load averages when the method finished (other processes on the cores
lengthen the wall time). Before the timed runs each method is called once on a 16 x 16 crop,
and the CPU seconds of that call are reported apart (``first_call_cpu_seconds``: compiling the
numba kernels when their on-disk cache is cold, loading it otherwise).

    python benchmarks/bench_photometric_stereo.py [--data ../shared/data] [--repeat 3]
        [--methods least_squares consensus ...]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from brdfkit.vision import (
    bivariate_stereo,
    consensus,
    datasets,
    inverse_rendering_stereo,
    photometric_stereo,
)
from brdfkit.vision.metrics import angular_error

METHODS = {**photometric_stereo.METHODS, **bivariate_stereo.METHODS, **consensus.METHODS}
METHODS |= inverse_rendering_stereo.METHODS


def main() -> None:
    """Render the stack once, then time each method and print JSON lines."""
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--methods", nargs="+", choices=list(METHODS), default=list(METHODS))
    args = parser.parse_args()
    gt = datasets.load_normal_integration(args.data / "normal_integration" / "diligent" / "bear")
    lights = datasets.diligent_like_lights()
    pixel_size = np.nanmean(gt.depth) / gt.camera[0, 0]
    lit = datasets.cast_shadows(-gt.depth, lights, pixel_size)
    data = datasets.render_synthetic(
        gt.normals,
        gt.mask,
        lights,
        albedo=[0.7, 0.5, 0.4],
        specular=0.5,
        shininess=50.0,
        lit=lit,
        noise=0.002,
        rng=np.random.default_rng(0),
    )
    cases = [("least_squares", None)] if "least_squares" in args.methods else []
    cases += [(name, data.mask) for name in args.methods]
    row, column = (int(c.mean()) for c in np.nonzero(data.mask))
    crop = data.images[:, row - 8 : row + 8, column - 8 : column + 8]  # inside the object
    records = []
    for name, mask in cases:
        start_cpu = time.process_time()
        METHODS[name](crop, data.light_directions)  # compiles the kernels or loads the cache
        first_call = time.process_time() - start_cpu
        best, cpu, iterations = np.inf, np.inf, 0
        for _ in range(args.repeat):
            steps: list[int] = []
            record = {"callback": lambda done, total, steps=steps: steps.append(done)}
            kwargs = {} if name in ("least_squares", "trimmed") else record
            start, start_cpu = time.perf_counter(), time.process_time()
            result = METHODS[name](data.images, data.light_directions, mask, **kwargs)
            seconds = time.perf_counter() - start
            if seconds < best:
                best, cpu = seconds, time.process_time() - start_cpu
            iterations = len(steps)
        errors = angular_error(result.normals, data.normals, data.mask)
        record = {
            "method": name,
            "stack": list(data.images.shape),
            "pixels": int(data.mask.size if mask is None else mask.sum()),
            "seconds": round(best, 4),
            "cpu_seconds": round(cpu, 4),
            "first_call_cpu_seconds": round(first_call, 3),
            "iterations": iterations,
            "mean_deg": round(errors["mean"], 3),
            "median_deg": round(errors["median"], 3),
            "loadavg": [round(x, 2) for x in os.getloadavg()],
        }
        print(json.dumps(record), flush=True)
        records.append(record)
    from _machine import header, results_path

    results = {**header(__file__), "repeat": args.repeat, "records": records}
    results_path(__file__).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
