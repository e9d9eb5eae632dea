"""Accuracy of photometric stereo and normal integration on real data.

1. The real psm gray sphere (12 images, ground truth from the mask's fitted circle), lights
   calibrated from the psm chrome sphere as ``brdfkit ps --chrome`` does: mean / median angular
   error in degrees of every method of ``brdfkit ps`` (``reconstruction.SOLVERS``).
2. The real DiLiGenT ground-truth normals of bear, cat, cow, goblet, harvest, pot1 and pot2
   integrated into depth by masked least squares (perspective, with the object's K, and
   orthographic), the DCT Poisson solver and Frankot-Chellappa: RMSE after fitting scale and
   offset to the ground-truth depth, % of its range (``metrics.depth_error``).

Everything at full resolution. Prints two Markdown tables, then one JSON line with all numbers,
and writes them to ``benchmarks/results/vision_accuracy.json``.

    python benchmarks/bench_vision_accuracy.py [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tqdm import tqdm

from brdfkit.io import data_path
from brdfkit.vision import datasets, photometric_stereo
from brdfkit.vision.metrics import angular_error, depth_error
from brdfkit.vision.normal_integration import METHODS as INTEGRATORS
from brdfkit.vision.reconstruction import SOLVERS

OBJECTS = ("bear", "cat", "cow", "goblet", "harvest", "pot1", "pot2")
"""The DiLiGenT objects with ground-truth normals, depth and K in the shared data."""

COLUMNS = {
    "ls_perspective": "LS perspective",
    "least_squares": "LS orthographic",
    "poisson_dct": "DCT Poisson",
    "frankot_chellappa": "Frankot–Chellappa",
}
"""Integration columns: the perspective solve, then every orthographic integrator."""


def psm_gray_sphere(data: Path) -> dict[str, dict[str, float]]:
    """Mean / median angular error (°) of each method on the gray sphere, chrome-sphere lights."""
    psm = data / "photometric_stereo" / "psm"
    chrome = datasets.load_psm(psm / "chrome")
    lights = photometric_stereo.calibrate_lights_chrome_sphere(chrome.images, chrome.mask)
    gray = datasets.load_psm(psm / "gray", light_directions=lights)
    errors = {}
    for name, solver in tqdm(SOLVERS.items(), desc="psm gray sphere"):
        result = solver(gray.images, gray.light_directions, gray.mask)
        error = angular_error(result.normals, gray.normals, gray.mask)
        errors[name] = {"mean": error["mean"], "median": error["median"]}
    return errors


def diligent_integration(data: Path) -> dict[str, dict[str, float]]:
    """Relative depth RMSE (% of range) of each integrator on each DiLiGenT object."""
    errors = {}
    for name in tqdm(OBJECTS, desc="normal integration"):
        gt = datasets.load_normal_integration(data / "normal_integration" / "diligent" / name)
        depths = {"ls_perspective": INTEGRATORS["least_squares"](gt.normals, gt.mask, gt.camera)}
        depths |= {method: f(gt.normals, gt.mask) for method, f in INTEGRATORS.items()}
        errors[name] = {
            method: 100 * depth_error(depth, gt.depth, gt.mask)["relative_rmse"]
            for method, depth in depths.items()
        }
    return errors


def main() -> None:
    """Compute both tables and print them as Markdown and as one JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="Shared data folder.")
    args = parser.parse_args()
    data = args.data if args.data is not None else data_path()
    ps = psm_gray_sphere(data)
    integration = diligent_integration(data)
    print("\n| method | mean (°) | median (°) |\n|---|---|---|")
    for name, error in ps.items():
        print(f"| {name} | {error['mean']:.2f} | {error['median']:.2f} |")
    print(f"\n| object | {' | '.join(COLUMNS.values())} |\n|---|{'---|' * len(COLUMNS)}")
    for name, row in integration.items():
        print(f"| {name} | {' | '.join(f'{row[key]:.2f}' for key in COLUMNS)} |")
    print()
    record = {"psm_gray_sphere": ps, "diligent_integration_rmse_percent": integration}
    print(json.dumps(record))
    from _machine import header, results_path

    results_path(__file__).write_text(json.dumps({**header(__file__), **record}, indent=1) + "\n")


if __name__ == "__main__":
    main()
