"""How close energy-compensated GGX dielectrics come to Heitz et al.'s (2016) random walk.

Over η ∈ {1.33, 1.5, 2.2, 1/1.5} × α ∈ {0.05, …, 1} × θo ∈ {0°, …, 84°}, from outside and
from inside: the reflected and transmitted flux albedo of
:class:`brdfkit.brdf.KullaContyDielectric` (single scattering by quadrature + the added
lobes, their eval integrated over ωi by quadrature), for the tabulated split
(``split="random_walk"``) and Kulla & Conty's split by the average Fresnel
(``"fresnel_average"``), against the walk (``PATHS`` paths, seeds independent of the
table's). Reported per method and lobe: the worst relative difference where the walk
resolves it (standard error < 0.5 % of the value), and the worst difference in standard
errors elsewhere (tiny R or T); and the worst |R + T − 1|.

``python benchmarks/kulla_conty_dielectric_accuracy.py [OUT.json]`` prints the results and, given
``OUT.json``, writes them there too. Deterministic; ~5 min CPU.
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np

from brdfkit.brdf import KullaContyDielectric
from brdfkit.brdf.kulla_conty_dielectric import SPLITS, added_albedo, dielectric_albedo
from brdfkit.brdf.random_walk import dielectric_random_walk_albedo
from brdfkit.io import atomic_write

ETAS = (1.33, 1.5, 2.2, 1 / 1.5)
ALPHAS = (0.05, 0.2, 0.4, 0.6, 0.8, 1.0)
THETAS = (0.0, 40.0, 60.0, 75.0, 84.0)
PATHS = 1 << 17


def main() -> None:
    worst = {
        split: {"R": [0.0, None, 0.0, None], "T": [0.0, None, 0.0, None], "sum": [0.0, None]}
        for split in SPLITS
    }
    for e, eta in enumerate(ETAS):
        for a, alpha in enumerate(ALPHAS):
            models = {
                split: KullaContyDielectric(alpha=alpha, eta=eta, split=split, mode="importance")
                for split in SPLITS
            }
            for t, degrees in enumerate(THETAS):
                for side in (1.0, -1.0):
                    theta = math.radians(degrees)
                    wo = np.array([math.sin(theta), 0.0, side * math.cos(theta)])
                    where = {"eta": round(eta, 4), "alpha": alpha, "theta": degrees, "side": side}
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", RuntimeWarning)
                        walk = dielectric_random_walk_albedo(
                            alpha, eta, wo, paths=PATHS, seed=200_000 + 1000 * e + 10 * a + t
                        )
                    reference = (walk.reflected, walk.transmitted)
                    single = dielectric_albedo(alpha, eta, np.array([wo[2]]))[0]
                    for split, model in models.items():
                        ours = single + added_albedo(model, wo)
                        row = worst[split]
                        if abs(ours.sum() - 1) > row["sum"][0]:
                            row["sum"] = [float(abs(ours.sum() - 1)), where]
                        for lobe, value, ref in zip("RT", ours, reference, strict=True):
                            if walk.stderr < 0.005 * ref:
                                error = float(value / ref - 1)
                                if abs(error) > abs(row[lobe][0]):
                                    row[lobe][:2] = [error, where]
                            else:
                                sigmas = float((value - ref) / walk.stderr)
                                if abs(sigmas) > abs(row[lobe][2]):
                                    row[lobe][2:] = [sigmas, where]
        print(f"η = {eta:.3f} done", flush=True)
    results = {
        split: {
            **{
                lobe: {
                    "worst_relative": row[lobe][0],
                    "at": row[lobe][1],
                    "worst_sigmas_unresolved": row[lobe][2],
                    "at_unresolved": row[lobe][3],
                }
                for lobe in "RT"
            },
            "worst_furnace": {"abs_R_plus_T_minus_1": row["sum"][0], "at": row["sum"][1]},
        }
        for split, row in worst.items()
    }
    if len(sys.argv) > 1:
        text = json.dumps(results, indent=2) + "\n"
        atomic_write(Path(sys.argv[1]), lambda tmp: tmp.write_text(text))
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
