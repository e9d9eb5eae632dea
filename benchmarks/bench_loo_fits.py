"""Leave-one-out over the shared measurements: are brdfkit fit's defaults chosen without a file
still good on it?

For each of the five shared measured files (four Cornell paints, the RGL felt) and each
configuration of :data:`CONFIGS` (model × objective, soft-L1 loss; the models include Lambertian
+ two GGX lobes), the mean CIEDE2000 of the measured and fitted spheres under the default light
(as ``bench_cornell_fits.py``). Then, per
held-out file, the configuration with the least mean over the *other four* files, and its score
on the held-out one. Prints a Markdown table; writes ``benchmarks/results/loo_fits.json``.

    python benchmarks/bench_loo_fits.py [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from brdfkit.fit import sphere_difference
from brdfkit.fit.analytic import fit
from brdfkit.io import data_path
from brdfkit.measured import read_cornell, read_rgl

FILES = (
    "cornell/acryl_blue.brdf",
    "cornell/cayman.brdf",
    "cornell/garnet_red.brdf",
    "cornell/krylon_blue.brdf",
    "rgl/acrylic_felt_green_rgb.bsdf",
)
CONFIGS = tuple(
    (model, objective)
    for model in ("lambertian + cook_torrance", "lambertian + ggx", "lambertian + ggx + ggx")
    for objective in ("cube_root", "log")
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None)
    args = parser.parse_args()
    folder = (args.data or data_path()) / "measured"
    scores: dict[tuple[str, str, str], float] = {}
    for name in FILES:
        path = folder / name
        measured = read_cornell(path) if path.suffix == ".brdf" else read_rgl(path)
        for model, objective in CONFIGS:
            result = fit(measured, model, objective=objective)
            scores[(name, model, objective)] = sphere_difference(
                measured, result.model, None, 96
            ).mean
            print(f"{name} {model} {objective}: {scores[(name, model, objective)]:.2f}", flush=True)
    rows = []
    print("\n| held-out file | configuration chosen on the other four | CIEDE2000 on it |")
    print("|---|---|---|")
    for held_out in FILES:
        others = [n for n in FILES if n != held_out]
        chosen = min(CONFIGS, key=lambda c: np.mean([scores[(n, *c)] for n in others]))
        value = scores[(held_out, *chosen)]
        rows.append(
            {"held_out": held_out, "model": chosen[0], "objective": chosen[1], "delta_e": value}
        )
        print(f"| {held_out} | {chosen[0]}, {chosen[1]} | {value:.2f} |")
    from _machine import header, results_path

    table = [
        {"file": k[0], "model": k[1], "objective": k[2], "delta_e": v} for k, v in scores.items()
    ]
    record = {**header(__file__), "scores": table, "leave_one_out": rows}
    results_path(__file__).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
