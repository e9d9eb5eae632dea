"""Photometric stereo at DiLiGenT size: 96 images of 612 x 512 pixels.

Renders the real DiLiGenT bear ground-truth normals (Lambertian + Blinn-Phong, attached and
cast shadows, noise; the real DiLiGenT images are not available here) and times every method,
least squares on every pixel of the stack and on the object mask, the robust ones on the mask.
Prints one JSON record per line: method, pixels, seconds (best of ``--repeat``), iterations and
the mean / median angular error in degrees.

    python benchmarks/bench_photometric_stereo.py [--data ../shared/data] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from brdfkit.vision import datasets
from brdfkit.vision.metrics import angular_error
from brdfkit.vision.photometric_stereo import METHODS


def main() -> None:
    """Render the stack once, then time each method and print JSON lines."""
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--repeat", type=int, default=3)
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
    cases = [("least_squares", None)] + [(name, data.mask) for name in METHODS]
    for name, mask in cases:
        best, iterations = np.inf, 0
        for _ in range(args.repeat if name in ("least_squares", "trimmed") else 1):
            steps: list[int] = []
            record = {"callback": lambda done, total, steps=steps: steps.append(done)}
            kwargs = {} if name in ("least_squares", "trimmed") else record
            start = time.perf_counter()
            result = METHODS[name](data.images, data.light_directions, mask, **kwargs)
            best = min(best, time.perf_counter() - start)
            iterations = len(steps)
        errors = angular_error(result.normals, data.normals, data.mask)
        record = {
            "method": name,
            "stack": list(data.images.shape),
            "pixels": int(data.mask.size if mask is None else mask.sum()),
            "seconds": round(best, 4),
            "iterations": iterations,
            "mean_deg": round(errors["mean"], 3),
            "median_deg": round(errors["median"], 3),
        }
        print(json.dumps(record), flush=True)


if __name__ == "__main__":
    main()
