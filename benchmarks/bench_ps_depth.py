"""The depth ``brdfkit ps`` writes: photometric-stereo normals integrated by each integrator.

On the DiLiGenT-layout renders of ``bench_ps_materials.py`` (the real DiLiGenT normals and
depth of each object in ``../shared/data/normal_integration/diligent``, 96 DiLiGenT-like lights,
cast shadows from the real depth, noise), the normals estimated by ``sparse_regression`` (the
default of ``brdfkit ps`` out of core) and ``shared_bivariate`` (its default) are integrated in
perspective (each object's ``K``) by ``least_squares`` and by ``bilateral_pieces`` (the default
of ``brdfkit integrate`` and of ``brdfkit ps``), and scored against the real depth as
``bench_normal_integration.py`` scores: MADE, the mean ``|s z - z_gt|`` in mm with ``s`` the
median of ``z_gt / z``. The ground-truth normals' own integration is the floor. Every
``--step``-th pixel (default 2).

    python benchmarks/bench_ps_depth.py [--data ../shared/data] [--objects bear ...]
        [--materials matte ...] [--step 2] [--noise 0.005]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from bench_normal_integration import made
from bench_ps_materials import material_brdf, render, shadowed_object
from brdfkit.vision import bivariate_stereo, datasets, photometric_stereo
from brdfkit.vision.depth_from_normals import METHODS as INTEGRATORS
from brdfkit.vision.metrics import angular_error

SOLVERS = {
    "sparse_regression": photometric_stereo.sparse_regression,
    "shared_bivariate": bivariate_stereo.shared_bivariate,
}
INTEGRATIONS = ("least_squares", "bilateral_pieces")
MATERIALS = ("matte", "ggx 0.1", "cornell krylon_blue")


def run_object(folder: Path, args: argparse.Namespace, rng) -> list[dict]:
    """Render each material on one object, solve, integrate and score."""
    lights = datasets.diligent_like_lights()
    o = shadowed_object(args.data, folder.name, args.step, lights)
    normals, mask, depth, camera = o.normals, o.mask, o.depth, o.camera
    floor = {name: made(INTEGRATORS[name](normals, mask, camera), depth) for name in INTEGRATIONS}
    records = []
    for material in args.materials:
        brdf = material_brdf(args.data, material)
        data = render(brdf, normals, mask, lights, o.lit, args.noise, rng)
        for solver, solve in SOLVERS.items():
            estimated = solve(data.images, lights, mask).normals
            record = {
                "object": folder.name, "material": material, "solver": solver,
                "pixels": int(mask.sum()),
                "angular_error_deg": angular_error(estimated, normals, mask)["mean"],
                "ground_truth_normals_made_mm": floor,
            }  # fmt: skip
            for name in INTEGRATIONS:
                start = time.perf_counter()
                z = INTEGRATORS[name](estimated, mask, camera)
                record[f"{name}_seconds"] = time.perf_counter() - start
                record[f"{name}_made_mm"] = made(z, depth)
            print(json.dumps(record), flush=True)
            records.append(record)
    return records


def main() -> None:
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--objects", nargs="+", default=None)
    parser.add_argument("--materials", nargs="+", default=list(MATERIALS))
    parser.add_argument("--step", type=int, default=2)
    parser.add_argument("--noise", type=float, default=0.005)
    args = parser.parse_args()
    root = args.data / "normal_integration" / "diligent"
    names = args.objects or sorted(p.name for p in root.iterdir() if p.is_dir())
    rng = np.random.default_rng(0)
    records = [r for name in names for r in run_object(root / name, args, rng)]
    wins = sum(r["bilateral_pieces_made_mm"] < r["least_squares_made_mm"] for r in records)
    summary = {
        "runs": len(records),
        "bilateral_pieces_below_least_squares": wins,
        **{
            f"{name}_mean_made_mm": {
                solver: float(np.mean([r[f"{name}_made_mm"] for r in records
                                       if r["solver"] == solver]))
                for solver in SOLVERS
            }
            for name in INTEGRATIONS
        },
    }  # fmt: skip
    print(json.dumps(summary))
    from _machine import write_results

    write_results(__file__, {
        "objects": names, "materials": args.materials, "step": args.step, "noise": args.noise,
        "integrations": list(INTEGRATIONS), "records": records, "summary": summary,
    })  # fmt: skip


if __name__ == "__main__":
    main()
