"""
The full Moon: Lambert against Lommel–Seeliger and Hapke
========================================================

Spheres lit from the camera (a directional light along the view: phase angle 0 everywhere, a
full Moon), rendered by :func:`brdfkit.render.render_sphere`, each scaled to its own maximum.
A Lambertian sphere darkens towards its limb as cos θ; the Lommel–Seeliger law
(:class:`~brdfkit.brdf.LommelSeeliger`) and Hapke's model with the opposition surge
(:class:`~brdfkit.brdf.Hapke`, lunar-like defaults) give the flat disk the Moon shows. The right
panel is Hapke's lobe f·cos θo in the plane of incidence (:func:`brdfkit.plot.lobe_plot`): the
peak points back to the light (grey arrows), the retroreflective opposition surge.

This is the README's picture ``docs/images/moon_hapke.png``: running this file as a script
writes it.
"""

import os
from pathlib import Path

import numpy as np

from brdfkit.brdf import Hapke, Lambertian, LommelSeeliger
from brdfkit.light import DirectionalLight
from brdfkit.plot import _figure, lobe_data, save
from brdfkit.render import render_sphere

models = {"Lambert": Lambertian(0.3), "Lommel–Seeliger": LommelSeeliger(0.3), "Hapke": Hapke()}
light = DirectionalLight((1.0, 0.0, 0.0))  # the default camera looks along −x
fig = _figure(figsize=(8.4, 2.6), layout="constrained")
axes = fig.subplots(1, 4, width_ratios=[1, 1, 1, 1.6])
for ax, (name, model) in zip(axes[:3], models.items(), strict=False):
    image = np.pad(render_sphere(model, light, resolution=128)[..., 0], 6)  # the disk fills it
    ax.imshow(image / image.max(), cmap="gray", vmin=0, vmax=1)
    ax.set_title(name, fontsize=9)
    ax.set_axis_off()
fig.delaxes(axes[3])
polar = fig.add_subplot(1, 4, 4, projection="polar")
polar.set_theta_zero_location("N")
polar.set_theta_direction(-1)
polar.set_thetamin(-90)
polar.set_thetamax(90)
for degrees in (0, 30, 60):
    theta, value = lobe_data(models["Hapke"], np.radians(degrees), cosine=True)
    polar.plot(theta, value, label=f"θi = {degrees}°")
    polar.annotate(
        "",
        xy=(-np.radians(degrees), polar.get_rmax()),
        xytext=(0, 0),
        arrowprops={"arrowstyle": "<-", "alpha": 0.3},
    )
polar.set_yticklabels([])
polar.set_title("Hapke f·cos θo", fontsize=9)
polar.legend(loc="lower center", fontsize=7, ncols=3, bbox_to_anchor=(0.5, -0.05))

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/moon_hapke.png", dpi=100)
