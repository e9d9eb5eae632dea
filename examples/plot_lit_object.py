"""
Materials on objects, with shadows
==================================

What people look at to judge a material is an object: the explorer's lit-object view and
``brdfkit atlas --objects`` show models on the meshes brdfkit ships
(:mod:`brdfkit.render.bundled_meshes`: a trefoil knot and a "shader ball", each over a ground,
generated from their formulas), lit by the bundled environment map in Mitsuba 3's frame, with
attached and cast shadows by rays through Embree (:func:`brdfkit.render.mesh.render_mesh`).
The command line renders the same images, e.g.::

    brdfkit render bundled:knot -b "ggx(alpha=0.2, material='Au')" \
        --look-at 2.4,2.3,3.4:0,0.55,0:0,1,0 --fov 40 -o knot.png

Here gold (GGX, α = 0.2) and a red rough plastic on both objects: the highlight follows the
curvature, the knot's loops shadow each other and the ground, and the shader ball's cup, a
concavity, stays darker than the convex ball (direct light only: no interreflection fills it).
Without Embree (the ``mesh`` extra) the script says so and draws nothing.
"""

import numpy as np
from matplotlib.figure import Figure

from brdfkit.brdf import parse
from brdfkit.data import default_envmap_path
from brdfkit.errors import ParameterError
from brdfkit.io import srgb_encode, tonemap
from brdfkit.light import EnvironmentMap
from brdfkit.render.bundled_meshes import load_mesh
from brdfkit.render.mesh import render_mesh
from brdfkit.render.mitsuba_frame import look_at_camera, mitsuba_oriented

PIXELS, SAMPLES = 128, 8
MODELS = {
    "gold, GGX α = 0.2": "ggx(alpha=0.2, material='Au')",
    "red rough plastic": "rough_plastic(diffuse_reflectance=[0.6, 0.05, 0.04], alpha=0.15)",
}
VIEWS = {
    "knot": ((2.4, 2.3, 3.4), (0.0, 0.55, 0.0)),
    "shaderball": ((1.6, 2.1, 2.8), (0.0, 0.6, 0.0)),
}
env = mitsuba_oriented(EnvironmentMap.from_file(default_envmap_path()))
images = {}
try:
    for mesh, (origin, target) in VIEWS.items():
        scene = load_mesh(f"bundled:{mesh}")
        camera = look_at_camera(origin, target, (0, 1, 0), fov=40, size=(PIXELS, PIXELS))
        for label, spec in MODELS.items():
            images[mesh, label] = render_mesh(
                scene, parse(spec), env, camera, PIXELS, samples=SAMPLES
            )
except ParameterError as error:  # Embree (the mesh extra) is not installed
    print(error)

# %%
# Each column a material, each row an object; one exposure for all.
if images:
    exposure = 1 / max(float(np.percentile(np.stack(list(images.values())), 99)), 1e-6)
    fig = Figure(figsize=(2.4 * len(MODELS), 2.4 * len(VIEWS)), layout="constrained")
    axes = fig.subplots(len(VIEWS), len(MODELS), squeeze=False)
    for (mesh, label), image in images.items():
        ax = axes[list(VIEWS).index(mesh)][list(MODELS).index(label)]
        ax.imshow(srgb_encode(tonemap(image * exposure)))
        ax.set_title(f"{label} on the {mesh}", fontsize="small")
        ax.set_xticks([])
        ax.set_yticks([])
