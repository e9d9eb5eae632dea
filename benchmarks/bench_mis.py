"""Variance of BRDF, light and MIS sampling of the reflection equation on real environment maps.

Prints a JSON record and a table: the mean per-query variance of each strategy at the same
number of samples per strategy, relative to the best, for 32 random normal/view pairs.

    python benchmarks/bench_mis.py [--data ../shared/data] [--samples 2048]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from brdfkit.brdf import parse
from brdfkit.integrate import reflected_radiance
from brdfkit.lights import EnvironmentMap

MAPS = (
    "probulator/grace.hdr",
    "probulator/uffizi.hdr",
    "polyhaven/royal_esplanade_1k.hdr",
    "polyhaven/venice_sunset_1k.hdr",
)
MODELS = ("ggx(alpha=0.1)", "lambertian(albedo=0.2) + ggx(alpha=0.1)")


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
    parser.add_argument("--samples", type=int, default=2048)
    args = parser.parse_args()
    wo, normals = queries()
    rows = []
    for name in MAPS:
        env = EnvironmentMap.from_file(Path(args.data) / "envmaps" / name)
        for spec in MODELS:
            brdf = parse(spec)
            variance = {
                m: float(
                    np.mean(
                        reflected_radiance(
                            brdf, env, wo, normal=normals, method=m, samples=args.samples
                        ).stderr
                        ** 2
                    )
                )
                for m in ("brdf", "light", "mis")
            }
            best = min(variance.values())
            rows.append(
                {
                    "map": name,
                    "brdf": spec,
                    "samples_per_strategy": args.samples,
                    "variance": variance,
                    "relative": {k: v / best for k, v in variance.items()},
                }
            )
            rel = rows[-1]["relative"]
            print(
                f"{name:36s} {spec:42s} brdf {rel['brdf']:8.2f}  light {rel['light']:8.2f}"
                f"  mis {rel['mis']:6.2f}"
            )
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
