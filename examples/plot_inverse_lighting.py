"""
Lighting from an image: nine spherical harmonics
================================================

A Lambertian object with known normals is a low-pass filter of its lighting (Ramamoorthi &
Hanrahan 2001): its image determines the nine spherical-harmonic coefficients (bands l ≤ 2) of
the light. Here a real light probe (Grace Cathedral, box-averaged to 32×64) lights a Lambertian
sphere (albedo 0.8), rendered by exact quadrature over the map's pixels, seen from the front
and from the back so that the whole sphere of normals is observed.
:func:`~brdfkit.vision.lighting.estimate_sh_lighting` fits the nine coefficients per channel
by least squares; the sphere re-rendered from them
(:func:`brdfkit.light.spherical_harmonics.irradiance_sh`) looks like the input, and the
coefficients are a few per
cent from the map's own projection (:func:`brdfkit.light.spherical_harmonics.project_latlong`): the
Lambertian kernel's l ≥ 4 part is what is left.

Without the shared data folder the example uses the environment map that ships with brdfkit.

This is the README's picture ``docs/images/inverse_lighting.png``: running this file as a
script writes it (with the real probe only).
"""

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from brdfkit.data import default_envmap_path
from brdfkit.io import data_path, read_image, srgb_encode
from brdfkit.light.spherical_harmonics import (
    irradiance_sh,
    latlong_directions,
    latlong_solid_angles,
    project_latlong,
)
from brdfkit.render import Sphere, gbuffer
from brdfkit.vision.lighting import estimate_sh_lighting

ALBEDO = 0.8
try:
    probe, name = data_path("envmaps", "probulator", "grace.hdr"), "grace probe"
except FileNotFoundError as missing:
    print(f"{missing}: using brdfkit's bundled map instead")
    probe, name = default_envmap_path(), "bundled map"
image = read_image(probe).astype(np.float64)
h, w = image.shape[0] // 32, image.shape[1] // 64
latlong = image[: 32 * h, : 64 * w].reshape(32, h, 64, w, 3).mean(axis=(1, 3))

# %%
# The sphere seen from the front (the default camera looks along −x, z up) and from the back
# (normals with x negated), side by side.
g = gbuffer(Sphere(), None, 96)
normals = np.concatenate([g.normals, g.normals * np.array([-1.0, 1.0, 1.0])], axis=1)
mask = np.concatenate([g.mask, g.mask], axis=1)

# Exact Lambertian image of the piecewise-constant map: ρ/π Σ L max(n·ω, 0) ΔΩ.
directions = latlong_directions(32, 64).reshape(-1, 3)
solid_angles = latlong_solid_angles(32, 64).reshape(-1)
weights = np.clip(normals.reshape(-1, 3) @ directions.T, 0, None) * solid_angles
rendered = ALBEDO / np.pi * (weights @ latlong.reshape(-1, 3))
rendered = rendered.reshape(*mask.shape, 3) * mask[..., None]

coeffs = estimate_sh_lighting(rendered, normals, mask, ALBEDO)
reference = project_latlong(latlong, 2)
error = np.linalg.norm(coeffs - reference) / np.linalg.norm(reference)
refit = ALBEDO / np.pi * irradiance_sh(coeffs, normals) * mask[..., None]
print(f"coefficients {100 * error:.1f} % from the map's projection")

# %%
# The spheres are exposed alike (the input's brightest pixel to 1), the probe (shown at its full
# resolution) by its 99th percentile; all sRGB-encoded.
scale = 1 / rendered.max()
fig = Figure(figsize=(6.75, 1.7), layout="constrained")
panels = [
    (f"{name} (input lighting)", image / np.percentile(image, 99)),
    ("Lambertian sphere, front + back", rendered * scale),
    (f"re-rendered from 9 fitted SH\n(coeff. error {100 * error:.1f}%)", refit * scale),
]
for ax, (title, picture) in zip(fig.subplots(1, 3), panels, strict=True):
    ax.imshow(srgb_encode(np.clip(picture, 0, 1)))
    ax.set_title(title, fontsize="small")
    ax.axis("off")

# %%
# Running the file as a script writes the README's picture (from the real probe only).
if "BRDFKIT_DOCS_BUILD" not in os.environ and name == "grace probe":
    fig.savefig(Path(__file__).resolve().parents[1] / "docs/images/inverse_lighting.png", dpi=100)
