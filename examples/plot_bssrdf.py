"""
Beyond the BRDF: a sphere with a BRDF and with a BSSRDF
=======================================================

The lectures' picture of subsurface scattering: the same diffuse colour as a BRDF (left, a
Lambertian sphere) and as a BSSRDF (right, Christensen–Burley's normalized diffusion,
:class:`~brdfkit.bssrdf.NormalizedDiffusion`, of a medium whose red light travels farthest),
under one directional light, rendered by :func:`brdfkit.bssrdf.subsurface_spheres`. Where the
light is uniform the two agree; at the terminator the translucent sphere bleeds light into the
shadow, reddest where it has travelled most — subsurface scattering makes surfaces look softer.

The medium comes from the colour by albedo inversion (:func:`brdfkit.bssrdf.invert_albedo`,
photon beam diffusion's total reflectance) and its mean free paths are 1/40, 1/80 and 1/160 of
the sphere's radius in red, green and blue.

This is the picture ``docs/images/bssrdf_spheres.png`` of the BSSRDF page: running this file as
a script writes it.
"""

import os
from pathlib import Path

import numpy as np

from brdfkit.bssrdf import (
    Medium,
    NormalizedDiffusion,
    PhotonBeamDiffusion,
    invert_albedo,
    subsurface_spheres,
)
from brdfkit.plot import _figure, encode_spheres, save

colour = [0.85, 0.55, 0.40]  # a skin-like diffuse colour
omega = invert_albedo(PhotonBeamDiffusion, colour, eta=1.4)
medium = Medium(omega, sigma_t=np.array([40.0, 80.0, 160.0]), eta=1.4)  # per sphere radius
brdf, bssrdf = subsurface_spheres(
    NormalizedDiffusion(medium), light=(0.2, 1.0, 0.5), resolution=160, samples=64
)
fig = _figure(figsize=(6.4, 3.4), layout="constrained")
for ax, image, title in zip(
    fig.subplots(1, 2),
    encode_spheres([np.pi * brdf, np.pi * bssrdf]),
    ("BRDF (Lambertian)", "BSSRDF (normalized diffusion)"),
    strict=True,
):
    ax.imshow(image)
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()

# %%
# Running the file as a script writes the BSSRDF page's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/bssrdf_spheres.png", dpi=100)
