"""Accuracy of Ramamoorthi–Hanrahan 9-coefficient irradiance on the real environment maps.

For every map in ``envmaps/`` (full resolution): the irradiance E(n) at 32×64 normals by
brute force over the map's pixels, E(n) = Σ L max(n·ω, 0) ΔΩ, against the 9-term SH
irradiance. Reports per map the solid-angle-weighted mean and the maximum of |E₉ − E|,
normalised by the map's largest irradiance (Ramamoorthi & Hanrahan's normalisation), and
pointwise relative to E; then the average over all maps. Prints a Markdown table and a JSON
record, and writes the record to ``benchmarks/results/sh.json``.

    python benchmarks/bench_sh.py [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from brdfkit import io
from brdfkit.light import spherical_harmonics as sh

NORMALS = (32, 64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="shared data folder")
    args = parser.parse_args()
    folder = (args.data or io.data_path()) / "envmaps"
    paths = sorted(folder.glob("*/*.hdr")) + sorted(folder.glob("*/*.exr"))
    normals = sh.latlong_directions(*NORMALS).reshape(-1, 3)
    weights = sh.latlong_solid_angles(*NORMALS).reshape(-1, 1) / (4 * np.pi)
    rows = []
    print("| map | pixels | mean / E_max | max / E_max | mean relative | max relative |")
    print("|---|---:|---:|---:|---:|---:|")
    for path in paths:
        image = io.read_image(path).astype(np.float64)[..., :3]
        brute = sh.irradiance_brute_force(image, normals)
        approx = sh.irradiance_sh(sh.project_latlong(image, 2), normals)
        error = np.abs(approx - brute)
        by_max = error / brute.max(axis=0)
        relative = error / brute
        row = {
            "map": str(path.relative_to(folder)),
            "pixels": f"{image.shape[1]}×{image.shape[0]}",
            # solid-angle-weighted mean over normals, averaged over RGB
            "mean_by_max": float(np.sum(by_max * weights, 0).mean()),
            "max_by_max": float(by_max.max()),
            "mean_relative": float(np.sum(relative * weights, 0).mean()),
            "max_relative": float(relative.max()),
        }
        rows.append(row)
        print(
            f"| {row['map']} | {row['pixels']} | {row['mean_by_max']:.2%} | "
            f"{row['max_by_max']:.2%} | {row['mean_relative']:.2%} | {row['max_relative']:.1%} |",
            flush=True,
        )
    mean = float(np.mean([r["mean_by_max"] for r in rows]))
    worst = float(np.max([r["max_by_max"] for r in rows]))
    print(f"\nAll {len(rows)} maps: mean error {mean:.2%} of E_max, largest {worst:.2%}")
    record = {"normals": list(NORMALS), "maps": rows, "mean_by_max": mean, "max_by_max": worst}
    print(json.dumps(record))
    from _machine import header, results_path

    results_path(__file__).write_text(json.dumps({**header(__file__), **record}, indent=1) + "\n")


if __name__ == "__main__":
    main()
