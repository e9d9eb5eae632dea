"""The directional albedo of every real-material preset, and the presets whose albedo exceeds 1.

For each preset of :func:`brdfkit.brdf.presets.catalogue`, ρ(θo) by 2048 importance samples
(scrambled Sobol) at θo = 0°, 20°, 40°, 60°, 75°, 85°; a preset exceeds 1 when
ρ − 3σ > 1 at some θo. Writes a JSON table to ``--out`` (default: print the summary only).

    python benchmarks/materials_albedo.py [--out albedo.json]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from brdfkit.brdf.presets import Material, catalogue
from brdfkit.geometry import spherical_to_cartesian

THETA_O = (0.0, 20.0, 40.0, 60.0, 75.0, 85.0)
SAMPLES = 2048


def albedo_table(samples: int = SAMPLES) -> list[dict]:
    theta = np.radians(THETA_O)
    wo = spherical_to_cartesian(theta, np.zeros_like(theta))
    rows = []
    for record in catalogue():
        model = Material(record["name"], record["fit"])
        mean, stderr = model.albedo_estimate(wo, samples=samples, seed=1)
        low = mean - 3 * stderr
        worst = np.unravel_index(int(np.argmax(mean)), mean.shape)
        rows.append(
            {
                "fit": record["fit"],
                "name": record["name"],
                "claims_energy": model.energy_conserving,
                "max_albedo": float(mean[worst]),
                "stderr": float(stderr[worst]),
                "theta_o": THETA_O[worst[0]],
                "exceeds_1": bool(np.any(low > 1)),
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out")
    args = parser.parse_args()
    rows = albedo_table()
    over = [r for r in rows if r["exceeds_1"]]
    print(f"{len(rows)} presets; {len(over)} with albedo > 1 (ρ − 3σ > 1 at some θo ≤ 85°):")
    for r in over:
        print(f"  {r['fit']:26s} {r['name']:28s} ρ = {r['max_albedo']:.3f} at {r['theta_o']:.0f}°")
    claimed = [r for r in rows if r["claims_energy"]]
    bad = [r for r in claimed if r["exceeds_1"]]
    print(f"{len(claimed)} presets claim energy conservation; {len(bad)} of them exceed 1")
    if args.out:
        with open(args.out, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=1)
    assert math.isfinite(sum(r["max_albedo"] for r in rows))


if __name__ == "__main__":
    main()
