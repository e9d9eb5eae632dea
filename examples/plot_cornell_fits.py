"""
Fitting analytic models to measured paints
==========================================

The four paints measured by the Cornell gonioreflectometer
(:func:`brdfkit.measured.read_cornell`: scattered spectral samples, converted to linear sRGB and
resampled onto a half/difference grid), each fitted by :func:`brdfkit.fit.fit` with
Lambertian + Cook–Torrance, Lambertian + GGX and Lambertian + Ward, with its default objective
and loss: ``cube_root`` (Forés et al. 2012) under the robust ``soft_l1``. A fit is judged by
eye: each fitted sphere is rendered beside the measured one under the same directional light
and exposed alike, and its mean CIEDE2000 difference from the measured sphere
(:func:`brdfkit.fit.sphere_difference`) is in its title; below about 12 reads as alike
at a glance.

``benchmarks/bench_cornell_fits.py`` also fits Lambertian alone and two GGX lobes, with every
objective and loss, under four lights (a few minutes). This example keeps three models and one
start per fit (the model's default values) instead of :func:`~brdfkit.fit.fit`'s four, so that
it runs in seconds; for these paints the fits come out the same (the ΔE in the README's table).
Without the shared data folder it fits a synthetic stand-in (an analytic red plastic sampled at
random direction pairs) instead.

This is the README's picture ``docs/images/cornell_fits.png``: running this file as a script
writes it (from the measured paints only).
"""

import os
from pathlib import Path

from matplotlib.figure import Figure

from brdfkit.brdf import parse
from brdfkit.fit import sphere_difference
from brdfkit.fit.analytic import fit
from brdfkit.io import data_path, srgb_encode
from brdfkit.measured import read_cornell

PAINTS = ("acryl_blue", "cayman", "garnet_red", "krylon_blue")
MODELS = {
    "+ Cook–Torrance": "lambertian + cook_torrance",
    "+ GGX": "lambertian + ggx",
    "+ Ward": "lambertian + ward",
}
try:
    folder = data_path("measured", "cornell")
    measured = {name: read_cornell(folder / f"{name}.brdf") for name in PAINTS}
except FileNotFoundError as missing:
    print(f"{missing}: fitting a synthetic stand-in instead")
    folder = None
    measured = {"synthetic plastic": parse("lambertian(rho=[0.45, 0.06, 0.04]) + ggx(alpha=0.2)")}

# %%
# Every fit, and its distance by eye from the measurement.
rows = {}
for name, table in measured.items():
    row = []
    for label, model in MODELS.items():
        # A Cornell file holds ~1,400 samples: the sample limits only matter for the stand-in.
        result = fit(table, model, starts=1, coarse_samples=2000, max_samples=2000)
        look = sphere_difference(table, result.model, resolution=96)
        row.append((f"{label}\nΔE {look.mean:.1f}", look.other))
        print(f"{name:18s} {model:28s} mean ΔE {look.mean:4.1f}  ({result.seconds:.1f} s)")
    rows[name] = [("measured", look.reference), *row]

# %%
# Rows: paints; columns: the measurement, then each fit (linear sRGB, encoded for display).
fig = Figure(figsize=(5.6, 1.55 * len(rows) + 0.3), layout="constrained")
axes = fig.subplots(len(rows), 4, squeeze=False)
for ax_row, (name, panels) in zip(axes, rows.items(), strict=True):
    for ax, (title, image) in zip(ax_row, panels, strict=True):
        ax.imshow(srgb_encode(image))
        ax.set_title(title, fontsize="small")
        ax.set_xticks([])
        ax.set_yticks([])
    ax_row[0].set_ylabel(name, fontsize="small")

# %%
# Running the file as a script writes the README's picture (from the measured paints only).
if "BRDFKIT_DOCS_BUILD" not in os.environ and folder is not None:
    fig.savefig(Path(__file__).resolve().parents[1] / "docs/images/cornell_fits.png", dpi=100)
