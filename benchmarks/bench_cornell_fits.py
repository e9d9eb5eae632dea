"""Lambertian (+ Cook–Torrance, + GGX, + Ward, + two GGX) fitted to the Cornell paints, by eye.

For every material and model, with the ``log`` and the ``cosine`` objective: the fitting errors
and the CIEDE2000 difference between the measured and the fitted sphere
(:func:`brdfkit.appearance.sphere_difference`, directional light). Writes a Markdown table on
stdout, every number to ``benchmarks/results/cornell_fits.json`` and the picture
``docs/images/cornell_fits.png`` (rows: materials; columns: measured, then each fit, ``log``
objective, exposed alike).

    python benchmarks/bench_cornell_fits.py [--data ../shared/data] [--resolution 96]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from brdfkit.appearance import sphere_difference
from brdfkit.fit import fit
from brdfkit.io import data_path, write_image
from brdfkit.measured import read_cornell

MATERIALS = ("acryl_blue", "cayman", "garnet_red", "krylon_blue")
PICTURED = ("lambertian + cook_torrance", "lambertian + ggx", "lambertian + ward")
MODELS = ("lambertian", *PICTURED, "lambertian + ggx + ggx")
OBJECTIVES = ("log", "cosine")
ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="shared data folder")
    parser.add_argument("--resolution", type=int, default=96)
    args = parser.parse_args()
    folder = (args.data or data_path()) / "measured" / "cornell"
    records, rows = [], []
    for material in MATERIALS:
        table = read_cornell(folder / f"{material}.brdf")
        row = []
        for model in MODELS:
            for objective in OBJECTIVES:
                result = fit(table, model, objective=objective)
                look = sphere_difference(table, result.model, resolution=args.resolution)
                records.append(
                    {
                        "material": material,
                        "model": model,
                        "objective": objective,
                        "delta_e": look.to_dict(),
                        "errors": result.errors,
                        "params": result.params,
                        "seconds": round(result.seconds, 2),
                        "success": result.success,
                    }
                )
                if objective == "log":
                    row = row or [look.reference]
                    if model in PICTURED:
                        row.append(look.other)
        rows.append(np.concatenate(row, axis=1))
    write_image(ROOT / "docs" / "images" / "cornell_fits.png", np.concatenate(rows, axis=0))
    results = ROOT / "benchmarks" / "results" / "cornell_fits.json"
    results.write_text(json.dumps(records, indent=1))
    print("mean CIEDE2000 between measured and fitted spheres (log objective; cosine in brackets)")
    print("| material | " + " | ".join(MODELS) + " |")
    print("|---" * (len(MODELS) + 1) + "|")
    for material in MATERIALS:
        cells = []
        for model in MODELS:
            de = {
                r["objective"]: r["delta_e"]["mean"]
                for r in records
                if r["material"] == material and r["model"] == model
            }
            cells.append(f"{de['log']:.1f} ({de['cosine']:.1f})")
        print(f"| {material} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
