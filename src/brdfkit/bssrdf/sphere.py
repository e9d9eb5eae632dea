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

from collections.abc import Callable
from typing import Any

import numpy as np

from brdfkit._array import normalize
from brdfkit._checks import as_float_array, check_count
from brdfkit.bssrdf.diffusion import DiffusionProfile, fresnel_moment
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.geometry import frame_from_normal, reflect
from brdfkit.light.base import Light
from brdfkit.light.environment import EnvironmentMap
from brdfkit.light.spherical_harmonics import latlong_directions
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
    inside, points = _front_view(resolution)
    albedo = model.total_reflectance()
    brdf = np.where(inside[..., None], albedo * np.maximum(points @ light, 0)[..., None] / np.pi, 0)
    visible = points[inside]
    exitance = np.stack(
        [
            _mean_irradiance(model, c, visible, lambda n: np.maximum(n @ light, 0), samples)
            for c in range(albedo.size)
        ],
        -1,
    )
    bssrdf = np.zeros_like(brdf)
    bssrdf[inside] = albedo * exitance / np.pi
    return brdf, bssrdf


def diffusion_sphere(
    model: DiffusionProfile,
    light: Light,
    resolution: int = 64,
    samples: int = 256,
) -> np.ndarray:
    r"""The translucent sphere of :func:`~brdfkit.bssrdf.sphere_walk.random_walk_sphere`
    rendered with the separable BSSRDF of ``model`` (:mod:`brdfkit.bssrdf.diffusion`) under a
    distant ``light`` without a delta, ``(resolution, resolution, C)`` at the pixel centres:

    .. math::
        L(x_o, \omega_o) = F(\mu_o)\,L_i(\omega_r) + \frac{1 - F(\mu_o)}{\pi\,c}\,
        \rho\,\mathbb{E}\bigl[E_t(x_i)\bigr],\qquad
        E_t(n) = \int L_i(\omega)\,\bigl(1 - F(n\cdot\omega)\bigr)\,
        \max(n\cdot\omega, 0)\,d\omega,

    the specular reflection of the light in the mirror direction :math:`\omega_r` plus the
    diffusion term: exit points drawn as in :func:`subsurface_spheres`, the power entering
    there, :math:`E_t` (tabulated on a 32 × 64 lat-long grid of normals by quadrature over a
    48 × 96 grid of directions, then looked up bilinearly), and the Fresnel transmittance of
    the exit normalised by :math:`c = 1 - 2\int_0^1 F(\mu, \eta)\,\mu\,d\mu` so that a
    uniform exitance leaves as a diffuse radiance (pbrt-v3's ``SeparableBSSRDF``).

    Claims: where the sphere is large against the diffusion length (mean free path 0.02 radii
    at ω = 0.9) the image is within the profile's table error of Mitsuba's ``volpath``;
    where it is not, the half-space assumption darkens it (``benchmarks/bench_bssrdf.py``).

    Parameters
    ----------
    model : the radial profile (its medium's lengths in sphere radii, its η the boundary's).
    light : distant light with no delta (an environment map, say).
    resolution : image side in pixels.
    samples : exit-point samples per pixel.

    References
    ----------
    .. [1] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A practical model for
           subsurface light transport", SIGGRAPH 2001.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 3rd ed., §11.4 (separable BSSRDFs), 2016.

    Examples
    --------
    A medium that does not absorb (ω = 1) under a uniform white sky: the sphere is white, its
    specular F and its diffusion part (1 − F)·ρ·E_t/(πc), with ρ = 1, add up to the sky's 1.

    >>> from brdfkit.bssrdf import BetterDipole, Medium
    >>> from brdfkit.light import EnvironmentMap
    >>> sky = EnvironmentMap(np.ones((8, 16, 1)))
    >>> image = diffusion_sphere(BetterDipole(Medium(1.0, 5.0, eta=1.33)), sky, 8, 64)
    >>> round(float(image[4, 4, 0]), 3), float(image[0, 0, 0])
    (1.0, 0.0)
    """
    if light.delta:
        raise ParameterError("light must have no delta (diffusion_sphere integrates it)")
    resolution = check_count("resolution", resolution, MAX_RESOLUTION)
    samples = check_count("samples", samples, 1 << 16)
    inside, points = _front_view(resolution)
    visible = points[inside]
    eta = float(np.asarray(model.medium.eta))
    towards_camera = np.broadcast_to([1.0, 0.0, 0.0], visible.shape)
    f_out = fresnel_dielectric(visible[:, 0], eta)
    specular = f_out[:, None] * light.incident_radiance(visible, reflect(towards_camera, visible))
    entering = _entering_power(light, eta)
    albedo = model.total_reflectance()
    diffuse = np.stack(
        [
            albedo[min(c, albedo.size - 1)]
            * _mean_irradiance(
                model,
                min(c, albedo.size - 1),
                visible,
                lambda n, c=c: entering.incident_radiance(np.zeros(3), n)[..., c],
                samples,
            )
            for c in range(light.channels)
        ],
        -1,
    )
    c_eta = 1 - 2 * float(fresnel_moment(1, 1 / eta))
    image = np.zeros((resolution, resolution, light.channels))
    image[inside] = specular + (1 - f_out)[:, None] * diffuse / (np.pi * c_eta)
    return image


def _front_view(resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """The pixels on the sphere and the sphere's points under every pixel centre (rows from +z
    down, columns +y; the camera on +x)."""
    coordinates = (np.arange(resolution) + 0.5) / resolution * 2 - 1
    z, y = -coordinates[:, None], coordinates[None, :]
    inside = y * y + z * z < 1
    points = np.stack(np.broadcast_arrays(np.sqrt(np.maximum(1 - y * y - z * z, 0)), y, z), -1)
    return inside, points


def _entering_power(light: Light, eta: float) -> EnvironmentMap:
    """:math:`E_t(n)` of :func:`diffusion_sphere` tabulated as a lat-long map of normals."""
    normals = latlong_directions(32, 64).reshape(-1, 3)
    directions = latlong_directions(48, 96).reshape(-1, 3)
    theta = np.pi * (np.arange(48) + 0.5) / 48
    solid_angle = np.repeat(np.sin(theta) * (np.pi / 48) * (2 * np.pi / 96), 96)
    radiance = light.incident_radiance(np.zeros(3), directions) * solid_angle[:, None]
    nodes = np.linspace(0.0, 1.0, 1025)
    transmitted = nodes * (1 - fresnel_dielectric(nodes, eta))  # μ (1 − F(μ)), interpolated
    cosine = np.maximum(normals @ directions.T, 0)
    table = np.interp(cosine, nodes, transmitted) @ radiance
    return EnvironmentMap(table.reshape(32, 64, -1))


def _mean_irradiance(
    model: DiffusionProfile,
    channel: int,
    points: np.ndarray,
    irradiance: Callable[[np.ndarray], np.ndarray],
    samples: int,
) -> np.ndarray:
    """The mean ``irradiance`` (of unit normals) over each point's exit samples (one channel's
    radii)."""
    u = sobol(samples, 2, seed=1)
    radius = model.sampler(channel).sample(u)
    phi = 2 * np.pi * u[:, 1]
    s, t, _ = frame_from_normal(points)
    offsets = (radius * np.cos(phi))[:, None, None] * s + (radius * np.sin(phi))[:, None, None] * t
    entries = normalize(points + offsets)  # projected onto the unit sphere
    return np.mean(irradiance(entries), axis=0)


__all__ = ["MAX_RESOLUTION", "diffusion_sphere", "subsurface_spheres"]
