"""
Thin-film iridescence
=====================

The colour a thin film reflects changes with its thickness (and with the angle): left, the
specular colour of a film of index 1.8 on glass (:class:`~brdfkit.brdf.ThinFilm`) for
thicknesses 0–1000 nm, at normal incidence and at 60°, from Belcour & Barla's closed-form
spectral integration (RGB mode) above the exact Airy spectrum summed over the CIE 1931
colour-matching functions for comparison; right, spheres coated with films
of three thicknesses under the default environment map, rendered by
:func:`brdfkit.render.render_sphere`.

This is the README's picture ``docs/images/thin_film.png``: running this file as a script
writes it.
"""

import os
from pathlib import Path

import numpy as np

from brdfkit.brdf import ThinFilm
from brdfkit.brdf.thin_film import airy_reflectance, xyz_to_linear_srgb
from brdfkit.data.colorimetry import observer
from brdfkit.io import srgb_encode
from brdfkit.light import parse_light
from brdfkit.plot import _figure, save
from brdfkit.render import render_sphere

FILM_ETA, BASE_ETA = 1.8, 1.5
thickness = np.linspace(0.0, 1000.0, 400)
wavelengths, xyz_bar = observer()
matrix = np.array(xyz_to_linear_srgb())


def strip(cos_theta: float, exact: bool) -> np.ndarray:
    """Linear-sRGB specular colours over ``thickness`` (rows of one image), scaled by 3."""
    if exact:
        r = airy_reflectance(
            np.full((thickness.size, 1), cos_theta),
            wavelengths,
            thickness[:, None],
            FILM_ETA,
            BASE_ETA,
            0.0,
        )
        rgb = (r @ xyz_bar / xyz_bar[:, 1].sum()) @ matrix.T
    else:
        rgb = np.stack(
            [
                ThinFilm(thickness=d, film_eta=FILM_ETA, eta=BASE_ETA).fresnel_term(
                    np.array([[cos_theta]])
                )[0]
                for d in thickness
            ]
        )
    return np.clip(3 * rgb, 0, 1)


fig = _figure(figsize=(8.4, 3.0), layout="constrained")
left, right = fig.subfigures(1, 2, width_ratios=[1.3, 1])
axes = left.subplots(4, 1, sharex=True)
rows = [
    (1.0, False, "0°, Belcour–Barla"),
    (1.0, True, "0°, exact spectrum"),
    (0.5, False, "60°, Belcour–Barla"),
    (0.5, True, "60°, exact spectrum"),
]
for ax, (cos_theta, exact, label) in zip(axes, rows, strict=True):
    ax.imshow(srgb_encode(strip(cos_theta, exact))[None], aspect="auto", extent=(0, 1000, 0, 1))
    ax.set_yticks([])
    ax.set_ylabel(label, rotation=0, ha="right", va="center", fontsize=7)
axes[-1].set_xlabel("film thickness (nm)", fontsize=8)
axes[-1].tick_params(labelsize=7)

light = parse_light("envmap:")
spheres = right.subplots(1, 3)
for ax, d in zip(spheres, (250.0, 400.0, 550.0), strict=True):
    model = ThinFilm(alpha=0.08, thickness=d, film_eta=FILM_ETA, eta=BASE_ETA)
    image = render_sphere(model, light, resolution=96, samples=64)
    ax.imshow(srgb_encode(np.clip(2 * image, 0, 1)))
    ax.set_title(f"d = {d:.0f} nm", fontsize=8)
    ax.set_axis_off()

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/thin_film.png", dpi=100)
