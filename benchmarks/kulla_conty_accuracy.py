"""How close energy-compensated GGX conductors come to Heitz et al.'s (2016) random walk.

For Au, Cu, Al and F = 1, over α ∈ {0.05, …, 1} × θo ∈ {0°, …, 84.9°}: the directional albedo
of :class:`brdfkit.brdf.KullaConty` (single scattering by quadrature + the added lobe, its
eval integrated over ωi by quadrature), of the published Kulla–Conty Fresnel term
(F_avg² E_avg / (1 − F_avg(1 − E_avg)) times the F = 1 lobe), and of the random walk
(``PATHS`` paths, seeds independent of those that built the table). Reported: the worst
relative difference to the walk per material and method, with where it occurs.

``python benchmarks/kulla_conty_accuracy.py [OUT.json]`` prints the results and, given
``OUT.json``, writes them there too. Deterministic; ~3 min on two busy cores.
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np

from brdfkit.brdf import KullaConty
from brdfkit.brdf.kulla_conty import ggx_albedo
from brdfkit.brdf.random_walk import random_walk_albedo
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.io import atomic_write

ALPHAS = (0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0)
THETAS = (0.0, 20.0, 40.0, 60.0, 75.0, 80.0, 84.9)
MATERIALS = ("Au", "Cu", "Al", "none")
PATHS = 1 << 17


def added_albedo(model: KullaConty, theta_o: float, n: int = 128) -> np.ndarray:
    """∫ (f − f_ss) cos θi dωi by Gauss–Legendre in √μi (the added lobe is isotropic)."""
    x, w = np.polynomial.legendre.leggauss(n)
    s, w = (x + 1) / 2, w / 2
    mu_i = s * s
    wi = np.stack([np.sqrt(1 - mu_i**2), np.zeros_like(mu_i), mu_i], axis=-1)
    wo = spherical_to_cartesian(np.array(theta_o), np.array(0.7))
    added = model.eval(wi, wo) - model._single.eval(wi, wo)
    return 2 * math.pi * np.sum((w * 2 * s * mu_i)[:, None] * added, axis=0)


def published_added_albedo(model: KullaConty, mu_o: float) -> np.ndarray:
    """Kulla & Conty's (2017) published term: F_avg² E_avg/(1 − F_avg(1 − E_avg)) (1 − E(μo))."""
    x, w = np.polynomial.legendre.leggauss(64)
    mu, w = (x + 1) / 2, w / 2
    fresnel = model._single.fresnel_term
    f_avg = np.sum((2 * w * mu)[:, None] * fresnel(mu[:, None]), axis=0)
    e = model.E(mu[:, None])
    e_avg = np.sum((2 * w * mu)[:, None] * e, axis=0)
    f_add = f_avg**2 * e_avg / (1 - f_avg * (1 - e_avg))
    return f_add * (1 - model.E(np.array([[mu_o]]))[0])


def main() -> None:
    results: dict[str, dict] = {}
    for material in MATERIALS:
        worst = {"tabulated": (0.0, None), "published": (0.0, None)}
        for a, alpha in enumerate(ALPHAS):
            model = KullaConty(alpha=alpha, material=material)
            fresnel = model._single.fresnel_term if material != "none" else None
            for t, degrees in enumerate(THETAS):
                theta = math.radians(degrees)
                wo = spherical_to_cartesian(np.array(theta), np.array(0.0))
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    walk = random_walk_albedo(
                        alpha, wo, fresnel=fresnel, paths=PATHS, seed=50_000 + 100 * a + t
                    )
                single = ggx_albedo(alpha, np.array([math.cos(theta)]), fresnel=fresnel)[0]
                ours = single + added_albedo(model, theta)
                theirs = single + published_added_albedo(model, math.cos(theta))
                for name, value in (("tabulated", ours), ("published", theirs)):
                    error = value / walk.albedo - 1
                    c = int(np.argmax(np.abs(error)))
                    if abs(error[c]) > abs(worst[name][0]):
                        worst[name] = (float(error[c]), {"alpha": alpha, "theta": degrees, "c": c})
        results[material] = {
            name: {"worst_relative": value, "at": where} for name, (value, where) in worst.items()
        }
        print(material, json.dumps(results[material]), flush=True)
    if len(sys.argv) > 1:
        text = json.dumps(results, indent=2) + "\n"
        atomic_write(Path(sys.argv[1]), lambda tmp: tmp.write_text(text))
    print("| material | tabulated R (this model) | published KC F_avg term |")
    print("|---|---|---|")
    for material, row in results.items():
        cells = [
            f"{100 * row[n]['worst_relative']:+.2f} % (α = {row[n]['at']['alpha']}, "
            f"θo = {row[n]['at']['theta']}°, channel {row[n]['at']['c']})"
            for n in ("tabulated", "published")
        ]
        print(f"| {material} | {cells[0]} | {cells[1]} |")


if __name__ == "__main__":
    main()
