"""Uncalibrated photometric stereo across real materials and on real photographs: each GBR cue.

(a) The DiLiGenT-layout renders of ``bench_ps_materials.py`` (real DiLiGenT normals and depth,
96 DiLiGenT-like lights of equal intensity, cast shadows, noise; analytic and measured
materials; the same stacks, seed and noise). Per (object, material) and cue of
:data:`brdfkit.vision.uncalibrated.CUES`: the lights' angular error (median over the lights,
°) against the rendered ones, and the normals' mean angular error (°) of a calibrated solver
run with the estimated lights — ``sparse_regression`` (what ``brdfkit ps`` runs out of core)
and ``shared_bivariate`` (the best calibrated method on these renders at this cost) — beside
the same solvers with the true lights. A cue that refuses the images (a matte object has no
specular highlights) is recorded as failed, with its message.

(b) The real psm photographs (12 lights, 8-bit): the lights of each cue against those
calibrated from the chrome sphere (an approximate reference, 1-9° from the student's
``lights.txt``); the gray sphere's normals against its mask's sphere.

Prints one JSON line per record and the tables; records go to
``benchmarks/results/uncalibrated.json``.

    python benchmarks/bench_uncalibrated.py [--data ../shared/data] [--objects bear cat pot1]
        [--step 8] [--noise 0.005]
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench_ps_materials import ANALYTIC, MEASURED, render_arguments, stacks
from brdfkit.errors import ParameterError
from brdfkit.vision import bivariate_stereo, datasets, photometric_stereo
from brdfkit.vision.metrics import angular_error
from brdfkit.vision.uncalibrated import CUES, uncalibrated

SOLVERS = {
    "sparse_regression": photometric_stereo.sparse_regression,
    "shared_bivariate": bivariate_stereo.shared_bivariate,
}
PSM_OBJECTS = ("gray", "cat", "horse", "owl")


def light_errors(estimated: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Angles (°) between matching rows of two sets of directions."""
    cosine = np.sum(estimated * reference, axis=1) / np.linalg.norm(reference, axis=1)
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def solve_cue(images: np.ndarray, mask: np.ndarray, cue: str, step: int) -> dict[str, Any]:
    """The lights of ``cue`` (and the cue ``auto`` chose), or the reason it refused."""
    start = time.perf_counter()
    try:
        estimate = uncalibrated(images, mask, cue=cue, sigma=1.0 / step)
    except ParameterError as error:
        return {"failed": str(error)}
    return {
        "estimate": estimate,
        "cue_used": estimate.cue,
        "seconds": round(time.perf_counter() - start, 3),
    }


def render_records(args: Any) -> list[dict[str, Any]]:
    """(a): per (object, material), the calibrated solvers and every cue."""
    records = []
    materials = list(ANALYTIC) + list(MEASURED)
    for name, material, data in stacks(args.data, args.objects, args.step, args.noise, materials):
        base = {"object": name, "material": material}
        calibrated = {
            solver: angular_error(
                solve(data.images, data.light_directions, data.mask).normals,
                data.normals, data.mask,
            )["mean"]
            for solver, solve in SOLVERS.items()
        }  # fmt: skip
        record = {**base, "cue": "calibrated", "normals_mean_deg": _rounded(calibrated)}
        records.append(record)
        print(json.dumps(record), flush=True)
        for cue in CUES:
            found = solve_cue(data.images, data.mask, cue, args.step)
            record = {**base, "cue": cue}
            if "failed" in found:
                record["failed"] = found["failed"]
            else:
                estimate = found["estimate"]
                scaled = data.images / estimate.light_intensities[:, None, None, None]
                errors = light_errors(estimate.light_directions, data.light_directions)
                normals = {
                    solver: angular_error(
                        solve(scaled, estimate.light_directions, data.mask).normals,
                        data.normals, data.mask,
                    )["mean"]
                    for solver, solve in SOLVERS.items()
                }  # fmt: skip
                record |= {
                    "cue_used": found["cue_used"],
                    "lights_median_deg": round(float(np.median(errors)), 3),
                    "lights_max_deg": round(float(errors.max()), 3),
                    "normals_mean_deg": _rounded(normals),
                    "seconds": found["seconds"],
                }
            records.append(record)
            print(json.dumps(record), flush=True)
    return records


def psm_records(data_dir: Path) -> list[dict[str, Any]]:
    """(b): every cue on the psm photographs, lights against the chrome sphere's."""
    psm = data_dir / "photometric_stereo" / "psm"
    chrome = datasets.load_psm(psm / "chrome")
    reference = photometric_stereo.calibrate_lights_chrome_sphere(chrome.images, chrome.mask)
    records = []
    for name in PSM_OBJECTS:
        data = datasets.load_psm(psm / name, light_directions=reference)
        for cue in CUES:
            found = solve_cue(data.images, data.mask, cue, 1)
            record: dict[str, Any] = {"psm": name, "cue": cue}
            if "failed" in found:
                record["failed"] = found["failed"]
            else:
                estimate = found["estimate"]
                errors = light_errors(estimate.light_directions, reference)
                record |= {
                    "cue_used": found["cue_used"],
                    "lights_median_deg": round(float(np.median(errors)), 3),
                    "lights_max_deg": round(float(errors.max()), 3),
                }
                if name == "gray":
                    normals = angular_error(estimate.result.normals, data.normals, data.mask)
                    record["normals_mean_deg"] = {"least_squares": round(normals["mean"], 3)}
            records.append(record)
            print(json.dumps(record), flush=True)
    return records


def _rounded(values: dict[str, float]) -> dict[str, float]:
    return {key: round(float(value), 3) for key, value in values.items()}


def main() -> None:
    """Run (a) and (b), write the results file, print the tables."""
    parser = render_arguments(__doc__.splitlines()[0])
    parser.set_defaults(step=8)
    args = parser.parse_args()
    results = {
        "objects": args.objects, "step": args.step, "noise": args.noise, "cues": list(CUES),
        "solvers": list(SOLVERS), "records": render_records(args),
        "psm": psm_records(args.data),
    }  # fmt: skip
    from _machine import write_results

    write_results(__file__, results)
    import tables

    print(tables.uncalibrated(results))


if __name__ == "__main__":
    main()
