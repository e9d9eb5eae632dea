"""
A fitted material in Mitsuba 3
==============================

A measurement becomes a material another renderer takes: the Cornell gonioreflectometer's red
garnet paint (:func:`brdfkit.measured.read_cornell`) is fitted with Lambertian + GGX
(:func:`brdfkit.fit.fit`; separable Smith masking, the one Mitsuba 3 evaluates, so that the
export is exact), exported as a Mitsuba ``<bsdf>`` document
(:func:`brdfkit.interop.to_mitsuba_xml`: a ``blendbsdf`` of ``diffuse`` and
``roughconductor``), and the same sphere is rendered under the same environment map by
Mitsuba 3 (``direct`` integrator, :mod:`brdfkit.interop.mitsuba`'s scene) and by brdfkit
(:func:`brdfkit.render.render_sphere`), side by side. The command line does the same with
``brdfkit fit garnet_red.brdf --model "lambertian + ggx(masking='smith_separable')" -o out
--export mitsuba``.

At 64 samples per pixel each image carries its Monte Carlo noise (Mitsuba's is the grain;
brdfkit's stratified samples are smoother): the printed relative RMSE between them is mostly
that noise (``tests/render/test_render_mitsuba.py`` shows converged renders agree to 1 %).

Without the shared data folder a synthetic red plastic stands in for the measurement; without
Mitsuba (the ``oracle`` extra) only brdfkit's sphere is drawn.
"""

import numpy as np
from matplotlib.figure import Figure

from brdfkit.brdf import parse
from brdfkit.data import default_envmap_path
from brdfkit.fit.analytic import fit
from brdfkit.interop import mitsuba as ms
from brdfkit.interop import to_mitsuba_xml
from brdfkit.io import data_path, srgb_encode, tonemap
from brdfkit.light import EnvironmentMap
from brdfkit.measured import read_cornell
from brdfkit.render import interior_mask, render_sphere

MODEL = "lambertian + ggx(masking='smith_separable')"
PIXELS, SAMPLES = 96, 64
try:
    measured = read_cornell(data_path("measured", "cornell", "garnet_red.brdf"))
except FileNotFoundError as missing:
    print(f"{missing}: fitting a synthetic stand-in instead")
    measured = parse("lambertian(rho=[0.45, 0.06, 0.04]) + ggx(alpha=0.2)")

# %%
# The fit, and the Mitsuba document it exports to.
result = fit(measured, MODEL, starts=1, coarse_samples=2000, max_samples=2000)
print(result.spec)
xml = to_mitsuba_xml(result.model)
print(xml)

# %%
# The same sphere, under the same map, in both renderers.
env = EnvironmentMap.from_file(default_envmap_path())
ours = render_sphere(result.model, env, resolution=PIXELS, samples=SAMPLES)
panels = [("brdfkit", ours)]
try:
    mi, _ = ms.load_mitsuba(("scalar_rgb",))
except ImportError as error:
    print(f"Mitsuba 3 is not available ({error}): brdfkit's sphere only")
else:
    scene = ms.sphere_scene(mi, mi.load_string(xml), env, PIXELS)
    theirs = ms.render(mi, scene, SAMPLES)
    panels.append(("Mitsuba 3", theirs))
    inside = interior_mask(PIXELS, margin=0.1)
    print(f"relative RMSE of the two images: {ms.relative_rmse(ours, theirs, inside):.3f}")

exposure = 1 / max(float(np.percentile(ours, 99)), 1e-6)
fig = Figure(figsize=(2.2 * len(panels), 2.4), layout="constrained")
for ax, (title, image) in zip(fig.subplots(1, len(panels), squeeze=False)[0], panels, strict=True):
    ax.imshow(srgb_encode(tonemap(image * exposure)))
    ax.set_title(title, fontsize="small")
    ax.set_xticks([])
    ax.set_yticks([])
