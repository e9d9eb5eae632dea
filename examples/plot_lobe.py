"""
Cook–Torrance lobes
===================

:func:`brdfkit.plot.lobe_plot` draws f·cos θo in the plane of incidence for several incidence
angles (θi = 0°, 30°, 60°; the grey arrows point to the light). The Cook–Torrance lobe
(:class:`~brdfkit.brdf.CookTorrance`, Beckmann slopes m = 0.3) grows and tilts towards grazing
as the light goes down: Fresnel and the 1/(cos θi cos θo) factor take over (off-specular
reflection). :func:`brdfkit.plot.lobe_data` returns the numbers drawn.

This is the README's picture ``docs/images/lobe_cook_torrance.png``: running this file as a
script writes it.
"""

import os
from pathlib import Path

from brdfkit.brdf import parse
from brdfkit.plot import lobe_plot, save

fig = lobe_plot(parse("cook_torrance(m=0.3)"))

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/lobe_cook_torrance.png", dpi=100)
