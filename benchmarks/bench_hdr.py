"""Camera response calibration on simulated exposure stacks: brdfkit's four methods against
OpenCV's ``createCalibrateDebevec`` and ``createCalibrateRobertson`` in the same run.

Each stack is a 96 × 96 RGB scene of log-uniform radiances (three decades, each channel its
own) photographed at seven exposure times a factor 2 apart through a real-looking response —
gamma 2.2, sRGB (IEC 61966-2-1), a filmic curve (Hable's "Uncharted 2" operator, which is no
member of the ``"emor"`` prior's family) and a cubic polynomial — with shot noise (a full well
of 10⁴ electrons), read noise (3 electrons) and 8-bit quantisation. The error of a recovered
inverse response is the RMS over the codes 1…254 of its difference from the true inverse, after
the one scale that every calibration leaves free is fitted (least squares), in % of the range
of the inverse (:math:`I(255) = 1`); the median over curves, channels and seeds is reported
per method. Stability: each brdfkit method at 50, 200, 1,000 and 5,000 sampled pixels.

    python benchmarks/bench_hdr.py [--seeds 3]
"""

from __future__ import annotations

import argparse
import json
import time

import cv2
import numpy as np

from brdfkit.io import srgb_encode
from brdfkit.vision.response import METHODS, calibrate_response, inverse_of

SIZE = 96
TIMES = 2.0 ** np.arange(-6, 1)
FULL_WELL = 10_000.0
READ_NOISE = 3.0
SAMPLE_COUNTS = (50, 200, 1000, 5000)
CODES = slice(1, 255)


def _hable(x: np.ndarray) -> np.ndarray:
    a, b, c, d, e, f = 0.15, 0.50, 0.10, 0.20, 0.02, 0.30
    return ((x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f)) - e / f


CURVES = {
    "gamma 2.2": lambda x: x ** (1 / 2.2),
    "sRGB": lambda x: np.asarray(srgb_encode(np.asarray(x, dtype=np.float64)), dtype=np.float64),
    "filmic (Hable)": lambda x: _hable(11.2 * x) / _hable(np.asarray(11.2)),
    "polynomial": lambda x: 1.6 * x - 0.9 * x**2 + 0.3 * x**3,
}
"""The true responses f: [0, 1] → [0, 1], f(1) = 1."""


def stack(curve, seed: int) -> np.ndarray:
    """(P, H, W, 3) uint8 codes of one scene through ``curve``, with noise."""
    rng = np.random.default_rng(seed)
    radiance = np.exp(rng.uniform(np.log(0.015), np.log(40.0), (SIZE, SIZE, 3)))
    images = []
    for t in TIMES:
        electrons = np.clip(radiance * t, 0, None) * FULL_WELL
        noisy = electrons + rng.normal(0, 1, electrons.shape) * np.sqrt(electrons + READ_NOISE**2)
        exposure = np.clip(noisy / FULL_WELL, 0, 1)
        images.append(np.round(255 * curve(exposure)).astype(np.uint8))
    return np.array(images)


def error_percent(estimate: np.ndarray, truth: np.ndarray) -> float:
    """RMS over codes 1…254 after the best scale, in % of the true curve's range."""
    e, t = estimate[CODES], truth[CODES]
    scale = float(e @ t / (e @ e)) if e @ e > 0 else 0.0
    return float(100 * np.sqrt(np.mean((scale * e - t) ** 2)) / (truth[-1] - truth[0]))


def opencv(images: np.ndarray, method: str) -> np.ndarray:
    """OpenCV's inverse response (256, 3), its defaults."""
    calibrate = (
        cv2.createCalibrateDebevec() if method == "debevec" else cv2.createCalibrateRobertson()
    )
    curve = calibrate.process(list(images[..., ::-1]), TIMES.astype(np.float32))
    return curve.reshape(256, 3)[:, ::-1].astype(np.float64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    cv2.setRNGSeed(0)
    records = []
    for name, curve in CURVES.items():
        truth = inverse_of(curve)
        for seed in range(args.seeds):
            images = stack(curve, seed)
            for method in ("debevec", "robertson"):
                began = time.perf_counter()
                estimate = opencv(images, method)
                seconds = time.perf_counter() - began
                errors = [error_percent(estimate[:, c], truth) for c in range(3)]
                records.append(_record(name, seed, f"OpenCV {method}", None, errors, seconds))
            for method in METHODS:
                for samples in SAMPLE_COUNTS:
                    began = time.perf_counter()
                    result = calibrate_response(images, TIMES, method, samples=samples,
                                                bootstrap=0, seed=seed)  # fmt: skip
                    seconds = time.perf_counter() - began
                    errors = [error_percent(result.inverse[:, c], truth) for c in range(3)]
                    records.append(_record(name, seed, method, samples, errors, seconds))
    from _machine import write_results

    summary = _summary(records)
    print(json.dumps(summary, indent=1))
    write_results(
        __file__,
        {"settings": _settings(args), "summary": summary, "records": records},
        packages=("opencv-python-headless",),
    )


def _record(curve, seed, method, samples, errors, seconds) -> dict:
    errors = [round(e, 4) for e in errors]
    record = {"curve": curve, "seed": seed, "method": method, "samples": samples,
              "error_percent": errors, "seconds": round(seconds, 3)}  # fmt: skip
    print(json.dumps(record), flush=True)
    return record


def _summary(records: list[dict]) -> dict:
    """Per method (brdfkit's at 1,000 samples): the median error over curves, channels and
    seeds, the median per curve; per brdfkit method the median at each sample count and the
    largest difference between those medians."""
    methods = ["OpenCV debevec", "OpenCV robertson", *METHODS]
    out: dict = {"median_error_percent": {}, "per_curve": {}, "by_samples": {}, "spread": {}}
    for method in methods:
        chosen = [r for r in records if r["method"] == method and r["samples"] in (None, 1000)]
        out["median_error_percent"][method] = round(
            float(np.median([e for r in chosen for e in r["error_percent"]])), 4
        )
        out["per_curve"][method] = {
            curve: round(float(np.median([e for r in chosen if r["curve"] == curve
                                          for e in r["error_percent"]])), 4)
            for curve in CURVES
        }  # fmt: skip
    for method in METHODS:
        medians = {
            n: round(float(np.median([e for r in records if r["method"] == method
                                      and r["samples"] == n for e in r["error_percent"]])), 4)
            for n in SAMPLE_COUNTS
        }  # fmt: skip
        out["by_samples"][method] = medians
        out["spread"][method] = round(max(medians.values()) - min(medians.values()), 4)
    return out


def _settings(args: argparse.Namespace) -> dict:
    return {"size": SIZE, "times": TIMES.tolist(), "full_well": FULL_WELL,
            "read_noise": READ_NOISE, "seeds": args.seeds, "curves": list(CURVES),
            "sample_counts": list(SAMPLE_COUNTS)}  # fmt: skip


if __name__ == "__main__":
    main()
