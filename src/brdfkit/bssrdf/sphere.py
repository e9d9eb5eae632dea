r"""A sphere under a directional light, with a BSSRDF and with the BRDF of the same albedo.

The lectures' picture of the BSSRDF: light entering at one point leaves at others, so a
translucent sphere looks softer than a Lambertian one of the same diffuse albedo — the
terminator blurs and light bleeds into the shadowed side. :func:`subsurface_spheres` renders
both images of an orthographic front view (the camera on +x, z up, as
:func:`brdfkit.render.render_sphere`), lit by a directional light of unit irradiance:

- BRDF: :math:`L = \rho\,\max(n\cdot l, 0)/\pi`, ρ the profile's total reflectance;
- BSSRDF: :math:`L(x_o) = M(x_o)/\pi` with the exitance
  :math:`M(x_o) = \int R_d(r)\,E(x_i)\,dA_i = \rho\,\mathbb{E}[E(x_i)]`, estimated with the
  same ``samples`` points for every pixel: radii drawn from the profile
  (:meth:`~brdfkit.bssrdf.diffusion.DiffusionProfile.sampler`, Sobol' points), placed in
  the tangent plane of :math:`x_o` and projected radially onto the sphere (the profile of a
  flat half-space applied to a surface curving slowly on the scale of the mean free path),
  where :math:`E = \max(n_i\cdot l, 0)`. The exit is Lambertian (the Fresnel factors of a
  separable BSSRDF left out), so where the light is uniform the two images agree.

References
----------
.. [1] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A practical model for subsurface
       light transport", SIGGRAPH 2001 (the BRDF and BSSRDF renders side by side).
.. [2] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 3rd ed., §11.4 and §15.4, 2016.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from brdfkit._array import normalize
from brdfkit._checks import as_float_array, check_count
from brdfkit.bssrdf.diffusion import DiffusionProfile
from brdfkit.geometry import frame_from_normal
from brdfkit.sampling import sobol

MAX_RESOLUTION = 2048
"""The largest image side :func:`subsurface_spheres` renders."""


def subsurface_spheres(
    model: DiffusionProfile,
    light: Any = (1.0, 1.0, 0.3),
    resolution: int = 128,
    samples: int = 256,
) -> tuple[np.ndarray, np.ndarray]:
    """``(brdf_image, bssrdf_image)``, each ``(resolution, resolution, C)``, of a unit sphere
    (module docstring); lengths of the model's medium are in sphere radii.

    Parameters
    ----------
    model : the radial profile (its medium's mean free path in sphere radii).
    light : the direction towards the light (world, normalised here).
    resolution : image side in pixels.
    samples : exit-point samples per pixel (a power of two keeps Sobol' points balanced).

    Examples
    --------
    A half-lit sphere: the translucent one sends light past the terminator:

    >>> from brdfkit.bssrdf import Medium, NormalizedDiffusion
    >>> model = NormalizedDiffusion(Medium(0.99, sigma_t=20.0, eta=1.33))
    >>> brdf, bssrdf = subsurface_spheres(model, light=(0.0, 1.0, 0.0), resolution=32)
    >>> dark = (slice(14, 18), slice(13, 16))  # just past the terminator, on the dark side
    >>> float(brdf[dark].max()), bool(bssrdf[dark].min() > 0.001)
    (0.0, True)
    """
    resolution = check_count("resolution", resolution, MAX_RESOLUTION)
    samples = check_count("samples", samples, 1 << 16)
    light = normalize(as_float_array("light", light).reshape(3))
    # the orthographic front view: pixel centres on [-1, 1]², rows from +z down, columns +y
    coordinates = (np.arange(resolution) + 0.5) / resolution * 2 - 1
    z, y = -coordinates[:, None], coordinates[None, :]
    inside = y * y + z * z < 1
    points = np.stack(np.broadcast_arrays(np.sqrt(np.maximum(1 - y * y - z * z, 0)), y, z), -1)
    albedo = model.total_reflectance()
    brdf = np.where(inside[..., None], albedo * np.maximum(points @ light, 0)[..., None] / np.pi, 0)
    visible = points[inside]
    exitance = np.stack(
        [_mean_irradiance(model, c, visible, light, samples) for c in range(albedo.size)], -1
    )
    bssrdf = np.zeros_like(brdf)
    bssrdf[inside] = albedo * exitance / np.pi
    return brdf, bssrdf


def _mean_irradiance(
    model: DiffusionProfile, channel: int, points: np.ndarray, light: np.ndarray, samples: int
) -> np.ndarray:
    """The mean irradiance over each point's exit samples (one channel's radii)."""
    u = sobol(samples, 2, seed=1)
    radius = model.sampler(channel).sample(u)
    phi = 2 * np.pi * u[:, 1]
    s, t, _ = frame_from_normal(points)
    offsets = (radius * np.cos(phi))[:, None, None] * s + (radius * np.sin(phi))[:, None, None] * t
    entries = normalize(points + offsets)  # projected onto the unit sphere
    return np.mean(np.maximum(entries @ light, 0), axis=0)


__all__ = ["MAX_RESOLUTION", "subsurface_spheres"]
