"""
Five models under the same light
================================

Five reflectance models side by side, each a spec string read by :func:`brdfkit.brdf.parse`,
rendered under the bundled environment map plus a directional light
(:class:`~brdfkit.light.DirectionalLight`) and exposed alike: Lambertian, Oren–Nayar's rough
diffuse (σ = 0.5), the energy-conserving modified Phong, Ward's anisotropic lobe, and a plastic
(Lambertian + GGX, the dichromatic model).

This is the README's picture ``docs/images/gallery_models.png``: running this file as a
script writes it.
"""

import os
from pathlib import Path

from brdfkit.brdf import parse
from brdfkit.data import default_envmap_path
from brdfkit.light import DirectionalLight, EnvironmentMap
from brdfkit.plot import save, sphere_gallery

env = EnvironmentMap.from_file(default_envmap_path())
sun = DirectionalLight((0.4, 0.5, 0.77), 2.0)
specs = {
    "Lambertian": "lambertian(rho=0.5)",
    "Oren–Nayar σ=0.5": "oren_nayar(rho=0.5, sigma=0.5)",
    "modified Phong": "modified_phong(kd=0.4, ks=0.3, n=60)",
    "Ward aniso.": "ward(kd=0.3, ks=0.2, alpha_x=0.08, alpha_y=0.3)",
    "plastic (Lamb.+GGX)": "lambertian(rho=[0.6, 0.2, 0.2]) + ggx(alpha=0.15)",
}
fig = sphere_gallery(
    [parse(s) for s in specs.values()], [env, sun], labels=list(specs), resolution=128, samples=64
)

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    save(fig, Path(__file__).resolve().parents[1] / "docs/images/gallery_models.png", dpi=100)
