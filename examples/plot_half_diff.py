"""
A half/difference slice
=======================

Rusinkiewicz's half/difference coordinates (:func:`brdfkit.geometry.to_half_diff`) separate
what a BRDF does with the half vector (θh: the highlight) from what it does with the angle
between the light and the half vector (θd: Fresnel and grazing effects). BRDF Explorer's
"image slice" is the θh × θd image at φd = 90°; :func:`brdfkit.plot.half_diff_plot` draws it beside
the θh and θd curves, here for a plastic (Lambertian + GGX, α = 0.1). The slice's numbers come
from :func:`brdfkit.plot.half_diff_data`.

This is the README's picture ``docs/images/half_diff_plastic.png``: running this file as a
script writes it.
"""

import os
from pathlib import Path

from brdfkit.brdf import parse
from brdfkit.plot import half_diff_plot, save

fig = half_diff_plot(parse("lambertian(albedo=0.3) + ggx(alpha=0.1)"))

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/half_diff_plastic.png", dpi=100)
