"""Calibrated photometric stereo across real materials, DiLiGenT-style: error per method, material.

DiLiGenT-layout image stacks are rendered from the real DiLiGenT ground-truth normals and depth
(``../shared/data/normal_integration/diligent``: bear, cat, pot1, ...; every ``--step``-th pixel;
or ``sphere``, a ball of DiLiGenT's size in its frame standing in for its ball) under 96
DiLiGenT-like lights, with cast shadows from the real depth and Gaussian noise, for each
material: the shared *measured* BRDFs (Cornell gonioreflectometer data, the RGL tensor
file; read with :mod:`brdfkit.measured`) and analytic specs (matte, and GGX lobes from broad
to sharp over a Lambertian base). The BRDF is evaluated in each pixel's local frame with the
library's own ``eval`` (the view is (0, 0, 1), orthographic), ``I = f_r(l, v) cos θ_i V``,
normalised to a 99th percentile of 1; noise is ``--noise`` of that.

Prints one JSON line per (object, material, method) — mean / median angular error (°) and
seconds — then a Markdown table of the mean error per material and method, averaged over the
objects (the DiLiGenT paper's table), with the best method of each row in bold. Every record
goes to ``benchmarks/results/ps_materials.json`` (``--out``: elsewhere).

    python benchmarks/bench_ps_materials.py [--data ../shared/data] [--objects bear cat pot1]
        [--step 4] [--noise 0.005] [--methods ...]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf.spec import parse
from brdfkit.geometry import frame_from_normal, to_local
from brdfkit.measured import read
from brdfkit.vision import (
    bivariate_stereo,
    consensus,
    datasets,
    inverse_rendering_stereo,
    photometric_stereo,
)
from brdfkit.vision.metrics import angular_error

METHODS = {**photometric_stereo.METHODS, **bivariate_stereo.METHODS, **consensus.METHODS}
METHODS |= inverse_rendering_stereo.METHODS

ANALYTIC = {
    "matte": "lambertian(albedo=[0.6, 0.5, 0.4])",
    "ggx 0.3": "lambertian(albedo=[0.5, 0.4, 0.3]) + 0.5 * ggx(alpha=0.3)",
    "ggx 0.1": "lambertian(albedo=[0.5, 0.4, 0.3]) + 0.3 * ggx(alpha=0.1)",
    "ggx 0.05": "lambertian(albedo=[0.4, 0.3, 0.2]) + 0.2 * ggx(alpha=0.05)",
}
MEASURED = {
    "cornell acryl_blue": "cornell/acryl_blue.brdf",
    "cornell cayman": "cornell/cayman.brdf",
    "cornell garnet_red": "cornell/garnet_red.brdf",
    "cornell krylon_blue": "cornell/krylon_blue.brdf",
    "rgl acrylic_felt_green": "rgl/acrylic_felt_green_rgb.bsdf",
}


def render(brdf, normals, mask, lights, lit, noise, rng) -> datasets.PhotometricStereoData:
    """Images ``f_r(l, v) cos θ_i V`` of ``brdf`` on ``normals`` (camera frame), grey-scaled
    to RGB if the BRDF has one channel, normalised to a 99th percentile of 1, plus noise."""
    n = normals[mask]
    frame = frame_from_normal(n)
    view = to_local(np.broadcast_to([0.0, 0.0, 1.0], n.shape), frame)
    images = np.zeros((len(lights), *mask.shape, 3))
    for k, light in enumerate(lights):
        wi = to_local(np.broadcast_to(light, n.shape), frame)
        value = np.asarray(brdf.eval(wi, view), dtype=np.float64)
        value = np.broadcast_to(value, (len(n), 3)) if value.shape[-1] == 1 else value[:, :3]
        cosine = np.clip(wi[:, 2], 0.0, None) * lit[k][mask]
        images[k][mask] = np.nan_to_num(value) * cosine[:, None]
    images /= np.percentile(images[:, mask].mean(axis=-1), 99)
    images = np.clip(images + rng.normal(0.0, noise, images.shape), 0.0, None) * mask[..., None]
    return datasets.PhotometricStereoData(
        images=images.astype(np.float32),
        light_directions=lights,
        mask=mask,
        normals=np.where(mask[..., None], normals, 0.0),
        light_intensities=np.ones((len(lights), 3)),
        name="synthetic",
    )


def render_arguments(description: str) -> argparse.ArgumentParser:
    """A parser with the renders' options (``--data``, ``--objects``, ``--step``,
    ``--noise``), shared with ``bench_bipolynomial.py``."""
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--objects", nargs="+", default=["bear", "cat", "pot1"])
    parser.add_argument("--step", type=int, default=4)
    parser.add_argument("--noise", type=float, default=0.005)
    return parser


def main() -> None:
    """Render every (object, material), run every method, print JSON lines and the table."""
    parser = render_arguments(__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--materials", nargs="+", default=list(ANALYTIC) + list(MEASURED))
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    methods = {m: METHODS[m] for m in args.methods}
    records = solve_all(args.data, args.objects, args.step, args.noise, args.materials, methods)
    from _machine import header, results_path

    out = args.out or results_path(__file__)
    out.parent.mkdir(parents=True, exist_ok=True)
    results = {
        **header(__file__),
        "objects": args.objects, "step": args.step, "noise": args.noise,
        "methods": args.methods, "materials": args.materials, "records": records,
    }  # fmt: skip
    out.write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    print(table(records, args.methods, args.materials))


@dataclass(frozen=True)
class ShadowedObject:
    """A real DiLiGenT object at every ``step``-th pixel: its normals, mask, depth (mm),
    intrinsics ``K`` scaled to the step, and the cast shadows ``lit`` ``(N, H, W)`` of its
    depth under the lights it was made for."""

    normals: np.ndarray
    mask: np.ndarray
    depth: np.ndarray
    camera: np.ndarray
    lit: np.ndarray


SPHERE_RADIUS = 120.0
"""Pixels: the ``sphere`` object's radius at full resolution (a ball like DiLiGenT's, about as
many pixels as its bear)."""


def sphere_object(step: int, lights: np.ndarray) -> ShadowedObject:
    """A sphere in DiLiGenT's frame (612 × 512 pixels, bear's ``K``, 1.5 m away), every
    ``step``-th pixel: orthographic normals, its depth (mm), no cast shadow (it is convex)."""
    focal, distance = 3772.0, 1500.0
    shape = (-(-512 // step), -(-612 // step))
    radius = SPHERE_RADIUS / step
    normals, mask = photometric_stereo.sphere_normals(shape, (306.0 / step, 256.0 / step), radius)
    depth = np.where(mask, distance - normals[..., 2] * radius * step * distance / focal, np.nan)
    camera = np.array([[focal / step, 0.0, 306.0 / step], [0.0, focal / step, 256.0 / step],
                       [0.0, 0.0, 1.0]])  # fmt: skip
    return ShadowedObject(normals, mask, depth, camera, np.ones((len(lights), *shape)))


def shadowed_object(data_dir: Path, name: str, step: int, lights: np.ndarray) -> ShadowedObject:
    """The object ``name`` of ``data_dir/normal_integration/diligent`` under ``lights``, or
    the :func:`sphere_object` for ``"sphere"``."""
    if name == "sphere":
        return sphere_object(step, lights)
    gt = datasets.load_normal_integration(data_dir / "normal_integration" / "diligent" / name)
    normals, mask, depth = (a[::step, ::step] for a in (gt.normals, gt.mask, gt.depth))
    pixel_size = np.nanmean(depth) / gt.camera[0, 0] * step
    lit = datasets.cast_shadows(-np.where(mask, depth, np.nan), lights, pixel_size)
    camera = gt.camera * np.array([[1 / step], [1 / step], [1]])
    return ShadowedObject(normals, mask, depth, camera, lit)


def material_brdf(data_dir: Path, material: str):
    """The BRDF of a material of :data:`ANALYTIC` or :data:`MEASURED`."""
    if material in ANALYTIC:
        return parse(ANALYTIC[material])
    return read(data_dir / "measured" / MEASURED[material])


def stacks(
    data_dir: Path, objects: list[str], step: int, noise: float, materials: list[str]
) -> Iterator[tuple[str, str, datasets.PhotometricStereoData]]:
    """``(object, material, data)`` for every (object, material), in that order: the noise
    from one seeded generator, so that every caller renders the same stacks."""
    rng = np.random.default_rng(0)
    lights = datasets.diligent_like_lights()
    for name in objects:
        o = shadowed_object(data_dir, name, step, lights)
        for material in materials:
            brdf = material_brdf(data_dir, material)
            yield name, material, render(brdf, o.normals, o.mask, lights, o.lit, noise, rng)


def solve_all(
    data_dir: Path,
    objects: list[str],
    step: int,
    noise: float,
    materials: list[str],
    methods: dict[str, Callable[..., Any]],
) -> list[dict[str, Any]]:
    """Run every method on every stack of :func:`stacks`: one record (and one JSON line
    printed) per (object, material, method), in that order."""
    records = []
    for name, material, data in stacks(data_dir, objects, step, noise, materials):
        for method, solve in methods.items():
            start = time.perf_counter()
            result = solve(data.images, data.light_directions, data.mask)
            seconds = time.perf_counter() - start
            errors = angular_error(result.normals, data.normals, data.mask)
            record = {
                "object": name,
                "material": material,
                "method": method,
                "pixels": int(data.mask.sum()),
                "mean_deg": round(errors["mean"], 3),
                "median_deg": round(errors["median"], 3),
                "seconds": round(seconds, 3),
            }
            records.append(record)
            print(json.dumps(record), flush=True)
    return records


def table(records: list[dict], methods: list[str], materials: list[str]) -> str:
    """Markdown: mean angular error (°) per material (rows) and method (columns), averaged
    over the objects; the best of each row in bold, and the row average at the bottom."""
    lines = ["| material | " + " | ".join(methods) + " | best |"]
    lines.append("|---|" + "---:|" * len(methods) + "---|")
    columns: dict[str, list[float]] = {m: [] for m in methods}
    for material in materials:
        means = {
            m: float(
                np.mean(
                    [
                        r["mean_deg"]
                        for r in records
                        if r["material"] == material and r["method"] == m
                    ]
                )
            )
            for m in methods
        }
        best = min(means, key=means.get)
        cells = [f"**{means[m]:.2f}**" if m == best else f"{means[m]:.2f}" for m in methods]
        lines.append(f"| {material} | " + " | ".join(cells) + f" | {best} |")
        for m in methods:
            columns[m].append(means[m])
    averages = {m: float(np.mean(v)) for m, v in columns.items()}
    best = min(averages, key=averages.get)
    cells = [f"**{averages[m]:.2f}**" if m == best else f"{averages[m]:.2f}" for m in methods]
    lines.append("| average | " + " | ".join(cells) + f" | {best} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
