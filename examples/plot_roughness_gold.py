"""
Gold with growing roughness
===========================

A row of gold spheres (:class:`~brdfkit.brdf.RoughConductor` with the tabulated complex index of
refraction of Au) under the environment map that ships with brdfkit, from a near-mirror
α = 0.03 to a rough α = 0.7. :func:`brdfkit.plot.sphere_gallery` renders every sphere by
multiple importance sampling of the map and the BRDF, and exposes the row alike.

This is the README's picture ``docs/images/gallery_ggx_gold.png``: running this file as a
script writes it.
"""

import os
from pathlib import Path

from brdfkit.brdf import RoughConductor
from brdfkit.data import default_envmap_path
from brdfkit.light import EnvironmentMap
from brdfkit.plot import save, sphere_gallery

env = EnvironmentMap.from_file(default_envmap_path())
alphas = [0.03, 0.1, 0.2, 0.4, 0.7]
models = [RoughConductor(alpha=a, material="Au") for a in alphas]
fig = sphere_gallery(
    models, env, labels=[f"Au, α = {a}" for a in alphas], resolution=128, samples=128
)

# %%
# The spheres are ordinary BRDF objects: the same row can be rendered with any model, e.g.
# ``parse("ggx(alpha=0.2, material='Cu')")``. Running the file as a script writes the
# README's picture (the documentation build only shows it).
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/gallery_ggx_gold.png", dpi=100)
