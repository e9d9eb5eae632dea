"""Rendering what a surface looks like: scenes, the reflection equation, images.

A render is two steps: a G-buffer from a shape seen by a camera (:mod:`~brdfkit.render.scene`),
then the reflection equation (:mod:`~brdfkit.render.reflection_equation`) at every covered pixel
(:mod:`~brdfkit.render.shading`), at once or in refining passes
(:mod:`~brdfkit.render.passes`). Spheres under an environment map can also be rendered without
noise by deterministic quadrature (:mod:`~brdfkit.render.environment_quadrature`). Triangle
meshes (:mod:`~brdfkit.render.mesh`) are traced by Embree, with shadows, in Mitsuba 3's frame
(:mod:`~brdfkit.render.mitsuba_frame`).
"""

from brdfkit.render.environment_quadrature import (
    QuadratureImage,
    quadrature_sphere,
    split_quadrature,
)
from brdfkit.render.mesh import MeshScene, render_mesh
from brdfkit.render.mitsuba_frame import look_at_camera
from brdfkit.render.passes import (
    Pass,
    progressive,
    progressive_sphere,
)
from brdfkit.render.reflection_equation import (
    Estimate,
    diffuse_floor,
    directional_albedo,
    hemispherical_reflectance,
    reflected_radiance,
    split_diffuse,
    split_mirror,
)
from brdfkit.render.scene import (
    Camera,
    Cylinder,
    GBuffer,
    Plane,
    Sphere,
    gbuffer,
    interior_mask,
    normal_map_gbuffer,
)
from brdfkit.render.shading import (
    render_sphere,
    shade,
    slice_brdf,
)

__all__ = [
    "Camera",
    "Cylinder",
    "Estimate",
    "GBuffer",
    "MeshScene",
    "Pass",
    "Plane",
    "QuadratureImage",
    "Sphere",
    "diffuse_floor",
    "directional_albedo",
    "gbuffer",
    "hemispherical_reflectance",
    "interior_mask",
    "look_at_camera",
    "normal_map_gbuffer",
    "progressive",
    "progressive_sphere",
    "quadrature_sphere",
    "reflected_radiance",
    "render_mesh",
    "render_sphere",
    "shade",
    "slice_brdf",
    "split_diffuse",
    "split_mirror",
    "split_quadrature",
]
