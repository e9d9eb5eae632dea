"""Relighting real photographs: leave 3 of the 12 psm lights out, predict those images.

For every psm object (buddha, cat, gray, horse, owl, rock; lights calibrated from the chrome
sphere) and every fold (held-out lights k, k + 4, k + 8 for k = 0..3), shape and reflectance are
recovered from the other 9 images and the 3 held-out images are rendered and compared with the
real ones: the Lambertian model of least-squares photometric stereo against the SVBRDF of
:func:`brdfkit.vision.svbrdf.fit_svbrdf` (Goldman et al. 2005; 1 and 2 Ward lobes, and
``svbrdf_cv``: the lobe count 0, 1 or 2 chosen by :func:`brdfkit.vision.svbrdf.select_lobes`,
3-fold cross-validation within the 9 training lights only — never the held-out ones). Each is
rendered without cast shadows, and with the shadows of the recovered shape (the same for every
model): the normals of the ``svbrdf_cv`` fit integrated to depth (orthographic, pixel units) and
marched by :func:`brdfkit.vision.svbrdf.shadow_visibility`, with the bias chosen on the 9 training
images by :func:`~brdfkit.vision.svbrdf.select_shadow_bias` ("chosen", possibly "no shadows") or
with bias 0, or with the shadows each model sees in its own training images ("observed"; all
settings: :data:`SHADOWS`). The error is the RMS over the mask's pixels and channels (images
in [0, 1]), on all pixels, on the pixels the held-out light reaches (real image above 5 % of its
99th percentile) and on the dark rest, and (``rms_gain``) on all pixels after each held-out
image's best gain (a diagnostic). Prints one JSON record per object, fold, model and shadow
setting, then Markdown tables of the means over the folds; every record and the means go to
``benchmarks/results/relighting.json``.

    python benchmarks/bench_relighting.py [--data ../shared/data] [--step 2] [--objects gray]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from functools import partial
from pathlib import Path

import numpy as np

from brdfkit.vision import datasets
from brdfkit.vision.normal_integration import least_squares_integration
from brdfkit.vision.photometric_stereo import (
    calibrate_lights_chrome_sphere,
    fit_circle,
    least_squares,
)
from brdfkit.vision.svbrdf import (
    fit_svbrdf,
    lambertian_relight,
    select_lobes,
    select_shadow_bias,
    shadow_visibility,
)
from brdfkit.vision.visibility import relit_visibility

OBJECTS = ("buddha", "cat", "gray", "horse", "owl", "rock")
MODELS = ("lambertian", "svbrdf_1", "svbrdf_2", "svbrdf_cv")
SHADOWS = ("off", "chosen", "bias0", "observed", "both")
"""No cast shadows; those of the bias chosen on the training images; those of bias 0; the
shadows each model sees in its own 9 training images, interpolated to the held-out lights
(:func:`brdfkit.vision.visibility.relit_visibility`, width and ratio chosen on the training
images); "both": the chosen cast shadows times the shadows each model still sees in its
training images rendered with those cast shadows (what the depth misses)."""


def errors(predicted: np.ndarray, real: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    """RMS of ``predicted - real`` (N, H, W, C) over the mask, its lit and its dark pixels, and
    ``rms_gain``: over the mask after each predicted image is scaled by its least-squares gain
    ``g_k = <P_k, I_k> / <P_k, P_k>`` (a diagnostic, not a prediction: it reads one number from
    each held-out photograph, and so removes the held-out lamp's unknown exposure)."""
    truth = real[:, mask]
    gray = truth.mean(axis=-1)
    lit = gray > 0.05 * np.percentile(gray, 99, axis=1, keepdims=True)
    values = predicted[:, mask]
    squared = (values - truth) ** 2
    gain = np.einsum("npc,npc->n", values, truth) / np.maximum(
        np.einsum("npc,npc->n", values, values), 1e-300
    )
    return {
        "rms": float(np.sqrt(squared.mean())),
        "rms_lit": float(np.sqrt(squared[lit].mean())),
        "rms_dark": float(np.sqrt(squared[~lit].mean())),
        "rms_gain": float(np.sqrt(np.mean((gain[:, None, None] * values - truth) ** 2))),
        "gains": [float(g) for g in gain],
    }


def sphere_depth_scale(normals: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    """Least-squares slope of the depth integrated from ``normals`` against the depth of the
    sphere of the mask's fitted radius (1: the scale is right), inside 0.9 of the radius."""
    c_x, c_y, radius = fit_circle(mask)
    rows, columns = np.indices(mask.shape)
    rho2 = (columns - c_x) ** 2 + (rows - c_y) ** 2
    inner = mask & (rho2 < (0.9 * radius) ** 2)
    sphere = -np.sqrt(radius**2 - rho2[inner])
    depth = least_squares_integration(normals, mask)[inner]
    design = np.stack([sphere, np.ones_like(sphere)], axis=1)
    (scale, offset), *_ = np.linalg.lstsq(design, depth, rcond=None)
    residual = depth - design @ (scale, offset)
    return {"radius_px": float(radius), "scale": float(scale),
            "rms_px": float(np.sqrt(np.mean(residual**2)))}  # fmt: skip


def main() -> None:
    """Every object, fold and model, without and with cast shadows: JSON lines, then tables."""
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--step", type=int, default=2)
    parser.add_argument("--objects", nargs="+", default=list(OBJECTS), choices=OBJECTS)
    parser.add_argument("--shadows", nargs="+", default=list(SHADOWS), choices=SHADOWS)
    args = parser.parse_args()
    psm = args.data / "photometric_stereo" / "psm"
    chrome = datasets.load_psm(psm / "chrome")
    lights = calibrate_lights_chrome_sphere(chrome.images, chrome.mask)
    table: dict[tuple[str, str, str], list[dict[str, float]]] = {}
    for name in args.objects:
        data = datasets.load_psm(psm / name, light_directions=lights, step=args.step)
        images = data.images.astype(np.float64)
        for fold in range(4):
            start = time.process_time()
            held = [fold, fold + 4, fold + 8]
            train = [k for k in range(12) if k not in held]
            real = images[held]
            ls = least_squares(images[train], lights[train], data.mask)
            fits = {lobes: fit_svbrdf(images[train], lights[train], data.mask, lobes=lobes)
                    for lobes in (1, 2)}  # fmt: skip
            chosen, _ = select_lobes(images[train], lights[train], data.mask)
            if chosen not in fits:
                fits[chosen] = fit_svbrdf(images[train], lights[train], data.mask, lobes=chosen)
            # The same shadows for every model: the depth of the cross-validated fit's normals
            # (fitted without the shadowed observations), with the bias chosen on the 9
            # training images only, or with none.
            shape = fits[chosen]
            bias, _ = select_shadow_bias(shape, images[train], lights[train])
            if data.normals is not None and fold == 0:
                scales = {"gt": sphere_depth_scale(data.normals, data.mask),
                          "least_squares": sphere_depth_scale(ls.normals, data.mask),
                          "svbrdf_cv": sphere_depth_scale(shape.normals, data.mask)}  # fmt: skip
                print(json.dumps({"object": name, "depth_scale": scales}), flush=True)
            renders = {
                "lambertian": partial(lambertian_relight, ls.albedo, ls.normals, data.mask),
                "svbrdf_1": fits[1].relight,
                "svbrdf_2": fits[2].relight,
                "svbrdf_cv": fits[chosen].relight,
            }
            settings = zip(SHADOWS, (None, bias, 0.0, None, bias), strict=True)
            for shadows, b in [(s, b) for s, b in settings if s in args.shadows]:
                geometric = None
                if b is not None:
                    geometric = shadow_visibility(shape.normals, data.mask, lights[held], bias=b)
                v = geometric
                predictions, choices = {}, {}
                for model, render in renders.items():
                    if shadows in ("observed", "both"):  # each model's own, on its training
                        trained = render(lights[train])  # renders (with the cast shadows)
                        if shadows == "both":
                            mask = data.mask
                            cast = shadow_visibility(shape.normals, mask, lights[train], bias=b)
                            trained = trained * cast[..., None]
                        v, choices[model] = relit_visibility(
                            trained, images[train], lights[train], data.mask, lights[held]
                        )
                        v = v if geometric is None else v * geometric
                    predictions[model] = render(lights[held]) * (1 if v is None else v[..., None])
                for model, predicted in predictions.items():
                    record = {"object": name, "held_out": held, "model": model,
                              "shadows": shadows}  # fmt: skip
                    record |= {"lobes": chosen} if model == "svbrdf_cv" else {}
                    if shadows in ("observed", "both"):  # (width, ratio) chosen, null: none
                        record["visibility"] = choices[model]
                    if geometric is not None:  # an infinite bias (no shadows) is written null
                        record["bias"] = b if np.isfinite(b) else None
                        record["shadowed"] = float(1 - geometric[:, data.mask].mean())
                    record |= errors(predicted, real, data.mask)
                    table.setdefault((name, model, shadows), []).append(record)
                    print(json.dumps(record), flush=True)
            print(json.dumps({"object": name, "fold": fold,
                              "cpu_s": time.process_time() - start}), flush=True)  # fmt: skip
    titles = (("rms", "all pixels"), ("rms_lit", "lit pixels"), ("rms_dark", "dark"),
              ("rms_gain", "all pixels, each held-out image at its best gain"))  # fmt: skip
    means: dict[str, dict[str, dict[str, dict[str, float]]]] = {}
    for key, title in titles:
        print(f"\nRMS, {title}, mean over the folds; cast shadows " + " / ".join(args.shadows))
        print("\n| object | " + " | ".join(MODELS) + " |")
        print("|---|" + "---|" * len(MODELS))
        for name in (*args.objects, "mean"):
            cells = []
            for model in MODELS:
                pair = []
                for shadows in args.shadows:
                    rows = [r for (o, m, s), rs in table.items()
                            if m == model and s == shadows and name in (o, "mean")
                            for r in rs]  # fmt: skip
                    pair.append(f"{np.mean([r[key] for r in rows]):.4f}")
                    cell = means.setdefault(name, {}).setdefault(model, {})
                    cell.setdefault(shadows, {})[key] = float(np.mean([r[key] for r in rows]))
                cells.append(" / ".join(pair))
            print(f"| {name} | " + " | ".join(cells) + " |")
    from _machine import header, results_path

    records = [r for rs in table.values() for r in rs]
    results = {**header(__file__), "step": args.step, "shadows": args.shadows,
               "means": means, "records": records}  # fmt: skip
    results_path(__file__).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
