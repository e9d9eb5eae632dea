"""Shape from shading at 128² … 512²: the cascadic solver against the single-level one.

Renders a Lambertian sphere (radius 5/12 of the image, light 21° off the view) at each size and
times :func:`brdfkit.vision.shape_from_shading.shape_from_shading` (cascadic multigrid above
4096 mask pixels); the peer is a single-level trust-region solve of the whole image
(``_solve_small``, from the tent start), run only up to ``--peer-max``
pixels across because its cost grows much faster. Prints one JSON line per (size, solver):
wall-clock seconds, CPU seconds of the process (all its threads: on a shared machine the wall
clock mostly measures the other users), residual evaluations and mean / median normal error (°);
writes them all to ``benchmarks/results/sfs.json``.

    python benchmarks/bench_sfs.py [--sizes 128 256 512] [--peer-max 96]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from scipy.ndimage import distance_transform_edt

from brdfkit.brdf import Lambertian
from brdfkit.light import DirectionalLight
from brdfkit.render import normal_map_gbuffer, shade
from brdfkit.vision import shape_from_shading as sfs
from brdfkit.vision.metrics import angular_error


def sphere(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Normals (x right, y up, z to the camera) and mask of a sphere of radius 5 size / 12."""
    radius = 5 * size / 12
    centre = size / 2 - 0.5
    x, y = np.meshgrid(np.arange(size) - centre, centre - np.arange(size))
    mask = x**2 + y**2 < (radius - 0.5) ** 2
    z = np.sqrt(np.clip(radius**2 - x**2 - y**2, 0, None))
    return np.where(mask[..., None], np.stack([x, y, z], -1) / radius, 0.0), mask


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=int, default=[128, 256, 512])
    parser.add_argument("--peer-max", type=int, default=96)
    args = parser.parse_args()
    light = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    records = []
    for size in sorted(set(args.sizes) | {s for s in (64, 96) if s <= args.peer_max}):
        normals, mask = sphere(size)
        gbuffer = normal_map_gbuffer(normals, mask)
        image = shade(gbuffer, Lambertian(1.0), DirectionalLight(direction=light, irradiance=np.pi))
        image = image[..., 0]
        runs = [("cascade", None)]
        if size <= args.peer_max:
            runs.append(("single-level trf", sfs._solve_small))
        for name, solver in runs:
            start, cpu = time.perf_counter(), time.process_time()
            if solver is None:
                result = sfs.shape_from_shading(image, light, mask, albedo=1.0)
                found, evaluations = result.normals, result.iterations
            else:
                z, evaluations, _ = solver(
                    image, mask, sfs._operators(mask), light, 1e-4,
                    distance_transform_edt(mask) / 2, 200,
                )  # fmt: skip
                depth = np.full(mask.shape, np.nan)
                depth[mask] = z
                found = sfs._normals_from_depth(depth, mask)
            seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
            errors = angular_error(found, normals, mask)
            record = {
                "size": size,
                "solver": name,
                "pixels": int(mask.sum()),
                "seconds": round(seconds, 2),
                "cpu_seconds": round(cpu, 2),
                "evaluations": int(evaluations),
                "mean_deg": round(errors["mean"], 3),
                "median_deg": round(errors["median"], 3),
            }
            print(json.dumps(record), flush=True)
            records.append(record)
    from _machine import header, results_path

    results = {**header(__file__), "records": records}
    results_path(__file__).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
