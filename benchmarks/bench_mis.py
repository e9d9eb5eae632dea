"""Error of BRDF, light and MIS sampling of the reflection equation on real environment maps.

For 32 random normal/view pairs per map and BRDF: the mean squared error of each estimator
(``--samples`` per strategy, ``--seeds`` independent runs) against a 65,536-sample MIS
reference, relative to the best; and the mean reported variance (stderr²) beside it, which
shows whether the standard error is honest. Prints a Markdown table and a JSON record, and
writes the record to ``benchmarks/results/mis.json``.

    python benchmarks/bench_mis.py [--data ../shared/data] [--samples 256] [--seeds 8]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from brdfkit.brdf import parse
from brdfkit.light import EnvironmentMap
from brdfkit.render import reflected_radiance

MAPS = (
    "probulator/grace.hdr",
    "probulator/uffizi.hdr",
    "polyhaven/royal_esplanade_1k.hdr",
    "polyhaven/venice_sunset_1k.hdr",
)
MODELS = ("ggx(alpha=0.1)", "lambertian(albedo=0.2) + ggx(alpha=0.1)")
ESTIMATORS = {  # name: (method, heuristic)
    "brdf": ("brdf", "power"),
    "light": ("light", "power"),
    "mis balance": ("mis", "balance"),
    "mis power": ("mis", "power"),
    "mis optimal": ("mis", "optimal"),
}


def queries(n: int = 32, seed: int = 5) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    normals = rng.normal(size=(n, 3))
    normals[:, 2] = np.abs(normals[:, 2]) + 0.05
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    wo = normals + 0.5 * rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    return np.where((np.sum(wo * normals, -1) > 0.1)[:, None], wo, normals), normals


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BRDFKIT_DATA", "../shared/data"))
    parser.add_argument("--samples", type=int, default=256)
    parser.add_argument("--seeds", type=int, default=8)
    args = parser.parse_args()
    wo, normals = queries()
    rows = []
    print("| map | BRDF | " + " | ".join(ESTIMATORS) + " |")
    print("|---|---|" + "---:|" * len(ESTIMATORS))
    for name in MAPS:
        env = EnvironmentMap.from_file(Path(args.data) / "envmaps" / name)
        for spec in MODELS:
            brdf = parse(spec)
            reference = reflected_radiance(
                brdf, env, wo, normal=normals, method="mis", samples=65536, seed=999
            ).value
            mse, reported = {}, {}
            for label, (method, heuristic) in ESTIMATORS.items():
                runs = [
                    reflected_radiance(
                        brdf,
                        env,
                        wo,
                        normal=normals,
                        method=method,
                        heuristic=heuristic,
                        samples=args.samples,
                        seed=seed,
                    )
                    for seed in range(args.seeds)
                ]
                mse[label] = float(np.mean([np.mean((r.value - reference) ** 2) for r in runs]))
                reported[label] = float(np.mean([np.mean(r.stderr**2) for r in runs]))
            best = min(mse.values())
            rows.append(
                {
                    "map": name,
                    "brdf": spec,
                    "samples_per_strategy": args.samples,
                    "seeds": args.seeds,
                    "mse": mse,
                    "reported_variance": reported,
                    "relative": {k: v / best for k, v in mse.items()},
                }
            )
            cells = " | ".join(
                f"{mse[k] / best:.2f} ({reported[k] / best:.2f})" for k in ESTIMATORS
            )
            print(f"| {name} | {spec} | {cells} |", flush=True)
    print(json.dumps(rows))
    from _machine import header, results_path

    record = {**header(__file__), "reference_samples": 65536, "rows": rows}
    results_path(__file__).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
