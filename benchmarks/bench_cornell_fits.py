"""Lambertian (+ Cook–Torrance, + GGX, + Ward, + two GGX) fitted to the Cornell paints, by eye.

For every material and model, with each objective and loss: the fitting errors and the CIEDE2000
difference between the measured and the fitted sphere
(:func:`brdfkit.fit.sphere_difference`) under the default directional light, and its mean
over :data:`LIGHTS` (four directions: head-on, the default, from the side, grazing). Writes two
Markdown tables on stdout, every number to ``benchmarks/results/cornell_fits.json`` and, with
``--image PATH``, the spheres (rows: materials; columns: measured, then each fit, default
objective and loss, exposed alike). The README's picture is made by
``examples/plot_cornell_fits.py``.

    python benchmarks/bench_cornell_fits.py [--data ../shared/data] [--resolution 96]
        [--loss-scale 0.5] [--image spheres.png]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from brdfkit.fit import sphere_difference
from brdfkit.fit.analytic import fit
from brdfkit.fit.appearance import DEFAULT_LIGHT_DIRECTION
from brdfkit.io import data_path, write_image
from brdfkit.light import DirectionalLight
from brdfkit.measured import read_cornell

MATERIALS = ("acryl_blue", "cayman", "garnet_red", "krylon_blue")
PICTURED = ("lambertian + cook_torrance", "lambertian + ggx", "lambertian + ward")
MODELS = ("lambertian", *PICTURED, "lambertian + ggx + ggx")
FITTINGS = tuple(
    (objective, loss)
    for objective in ("cube_root", "log", "cosine")
    for loss in ("soft_l1", "linear")
)
"""(objective, loss) pairs; the first is :func:`brdfkit.fit.fit`'s default."""
LIGHTS = ((0.0, 0.0, 1.0), DEFAULT_LIGHT_DIRECTION, (0.8, 0.2, 0.56), (0.9, 0.1, 0.2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="shared data folder")
    parser.add_argument("--resolution", type=int, default=96)
    parser.add_argument("--loss-scale", type=float, default=0.5, help="fit's loss_scale")
    parser.add_argument("--image", type=Path, help="write the measured and fitted spheres here")
    args = parser.parse_args()
    folder = (args.data or data_path()) / "measured" / "cornell"
    records, rows = [], []
    for material in MATERIALS:
        table = read_cornell(folder / f"{material}.brdf")
        row = []
        for model in MODELS:
            for objective, loss in FITTINGS:
                result = fit(
                    table, model, objective=objective, loss=loss, loss_scale=args.loss_scale
                )
                lit = [
                    sphere_difference(
                        table,
                        result.model,
                        [DirectionalLight(direction=direction, irradiance=np.pi)],
                        resolution=args.resolution,
                    )
                    for direction in LIGHTS
                ]
                look = lit[LIGHTS.index(DEFAULT_LIGHT_DIRECTION)]
                records.append(
                    {
                        "material": material,
                        "model": model,
                        "objective": objective,
                        "loss": loss,
                        "loss_scale": result.loss_scale,
                        "delta_e": look.to_dict(),
                        "delta_e_per_light": {
                            str(d): x.mean for d, x in zip(LIGHTS, lit, strict=True)
                        },
                        "errors": result.errors,
                        "params": result.params,
                        "seconds": round(result.seconds, 2),
                        "success": result.success,
                    }
                )
                if (objective, loss) == FITTINGS[0]:
                    row = row or [look.reference]
                    if model in PICTURED:
                        row.append(look.other)
        rows.append(np.concatenate(row, axis=1))
    if args.image is not None:
        write_image(args.image, np.concatenate(rows, axis=0))
    from _machine import header, results_path

    results = {**header(__file__), "records": records}
    results_path(__file__).write_text(json.dumps(results, indent=1, ensure_ascii=False) + "\n")

    def cell(material: str, model: str, fitting: tuple[str, str], averaged: bool) -> float:
        (record,) = (
            r
            for r in records
            if (r["material"], r["model"]) == (material, model)
            and (r["objective"], r["loss"]) == fitting
        )
        if averaged:
            return float(np.mean(list(record["delta_e_per_light"].values())))
        return record["delta_e"]["mean"]

    names = ["/".join(f) for f in FITTINGS]
    for title, averaged in (
        ("under the default light", False),
        (f"averaged over {len(LIGHTS)} light directions", True),
    ):
        print(f"\nmean CIEDE2000, measured vs fitted sphere, {title}")
        print(f"({names[0]}; {', '.join(names[1:])} in brackets)\n")
        print("| material | " + " | ".join(MODELS) + " |")
        print("|---" * (len(MODELS) + 1) + "|")
        for material in MATERIALS:
            cells = []
            for model in MODELS:
                first, *rest = (cell(material, model, f, averaged) for f in FITTINGS)
                cells.append(f"{first:.1f} (" + ", ".join(f"{v:.1f}" for v in rest) + ")")
            print(f"| {material} | " + " | ".join(cells) + " |")
        totals = {
            name: np.mean([cell(m, d, f, averaged) for m in MATERIALS for d in MODELS[1:]])
            for name, f in zip(names, FITTINGS, strict=True)
        }
        print(
            "\nmean over the fits with a specular lobe: "
            + ", ".join(f"{name} {v:.1f}" for name, v in totals.items())
        )


if __name__ == "__main__":
    main()
