"""
Diffuse/specular separation with the dichromatic model
======================================================

The dichromatic model (Shafer 1985) writes a pixel as a body colour times a diffuse shading
plus the illuminant's colour times a specular shading. A two-coloured Lambertian sphere plus a
grey Blinn–Phong highlight, under a coloured directional light, is rendered here with each lobe
alone, so the true diffuse and specular images are known.
:func:`~brdfkit.vision.separation.separate_dichromatic` (Yang, Wang & Ahuja 2010) white-balances
by the illuminant's colour, propagates the diffuse maximum chromaticity into the highlight by a
joint bilateral filter and returns both parts; the PSNR of the estimated diffuse image against
the true one is in its title. A faint leak remains near the colour edge, where the shading is
dark.

This is the README's picture ``docs/images/inverse_separation.png``: running this file as a
script writes it.
"""

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from brdfkit.brdf import Lambertian, parse
from brdfkit.io import srgb_encode
from brdfkit.light import DirectionalLight
from brdfkit.render import Sphere, gbuffer, shade
from brdfkit.vision.separation import separate_dichromatic

SIZE = 96
ILLUMINANT = np.array([2.0, 1.6, 1.2])
g = gbuffer(Sphere(), None, SIZE)
left = np.arange(SIZE)[None, :, None] < SIZE // 2
albedo = np.where(left, [0.7, 0.3, 0.1], [0.15, 0.3, 0.6]) * np.ones((SIZE, 1, 1))
light = DirectionalLight(direction=(1.0, 0.3, 0.4), irradiance=ILLUMINANT)
diffuse = shade(g, Lambertian(albedo), light)
specular = shade(g, parse("blinn_phong(kd=0, ks=0.3, n=60)"), light)
image = diffuse + specular

# %%
# The separation, and how far its diffuse image is from the truth (and the input from it).
result = separate_dichromatic(image, ILLUMINANT)


def psnr(estimate: np.ndarray, truth: np.ndarray) -> float:
    error = np.mean((estimate - truth)[g.mask] ** 2)
    return float(10 * np.log10(truth[g.mask].max() ** 2 / error))


print(f"diffuse {psnr(result.diffuse, diffuse):.1f} dB (the input: {psnr(image, diffuse):.1f} dB)")
relative = np.linalg.norm((result.specular - specular)[g.mask]) / np.linalg.norm(specular[g.mask])
print(f"specular {100 * relative:.1f} % relative L2 error")

# %%
# All four images share one exposure (the input's brightest value to 1), sRGB-encoded.
fig = Figure(figsize=(6.75, 1.8), layout="constrained")
panels = [
    ("input (Lambertian + Blinn–Phong)", image),
    (f"estimated diffuse ({psnr(result.diffuse, diffuse):.0f} dB)", result.diffuse),
    ("estimated specular", result.specular),
    ("true specular", specular),
]
for ax, (title, picture) in zip(fig.subplots(1, 4), panels, strict=True):
    ax.imshow(srgb_encode(np.clip(picture / image.max(), 0, 1)))
    ax.set_title(title, fontsize=7.5)
    ax.axis("off")

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    fig.savefig(Path(__file__).resolve().parents[1] / "docs/images/inverse_separation.png", dpi=100)
