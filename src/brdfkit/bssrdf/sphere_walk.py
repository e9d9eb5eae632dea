r"""The reference render of a translucent sphere: volumetric path tracing, no diffusion model.

A unit sphere filled with a homogeneous :class:`~brdfkit.bssrdf.Medium` (lengths in sphere
radii) behind a smooth dielectric boundary of index η, seen by the orthographic front view of
:func:`brdfkit.bssrdf.subsurface_spheres` (camera on +x, z up; every sample at a uniform
position inside its pixel, a box filter) and lit by a distant :class:`~brdfkit.light.Light`
without a delta (an :class:`~brdfkit.light.EnvironmentMap`, say). Each camera path is the
analog simulation of light transport, traced from the camera:

1. at the boundary, it is reflected with probability :math:`F(\mu)` (:func:`brdfkit.fresnel.
   fresnel_dielectric`, from outside or, with total internal reflection, from inside) and
   refracted otherwise (:func:`brdfkit.geometry.refract`);
2. inside, a free path :math:`s = -\ln u/\sigma_t` is drawn; a path that reaches the boundary
   first meets it there (step 1), else it scatters by the phase function
   (:func:`~brdfkit.bssrdf.medium.sample_henyey_greenstein`) with probability ω and is
   absorbed (its value 0) otherwise;
3. a path leaving the sphere in direction ω carries the light's :math:`L(\omega)`.

The pixel value is the mean over its paths and its standard error their spread over
:math:`\sqrt{n}`: an unbiased estimate of the radiance (paths still inside after
:data:`MAX_EVENTS` events are counted as dark; only ω ≈ 1 sees paths that long). This is
what Mitsuba 3's ``volpath`` integrator computes for a ``dielectric`` sphere with a
``homogeneous`` interior, the image the diffusion models of :mod:`brdfkit.bssrdf` approximate.

References
----------
.. [1] E. Veach, *Robust Monte Carlo Methods for Light Transport Simulation*, PhD thesis,
       Stanford, 1997, ch. 3 (the path integral with participating media).
.. [2] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 3rd ed., §14.5 (volumetric path tracing),
       2016.
"""

from __future__ import annotations

import numpy as np

from brdfkit._checks import check_count
from brdfkit.bssrdf.medium import Medium, sample_henyey_greenstein
from brdfkit.errors import ParameterError, ResourceError
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.geometry import frame_from_normal, reflect, refract, to_world
from brdfkit.light.base import Light

MAX_EVENTS = 100_000
"""Events after which a path still inside the sphere is counted as dark."""

CHUNK = 1 << 17
"""Paths traced together (memory: a few hundred bytes each)."""

MAX_PATHS = 1 << 26
"""The most paths (pixels × samples) one render traces (each path's value is kept for the
standard error: 8 bytes per channel)."""


def random_walk_sphere(
    medium: Medium,
    light: Light,
    resolution: int = 64,
    samples: int = 64,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """``(image, stderr)``, each ``(resolution, resolution, C)``: the sphere's radiance by
    volumetric path tracing (module docstring) and each pixel's standard error.

    Parameters
    ----------
    medium : a grey medium (scalar ω, σt in inverse sphere radii, g, η).
    light : distant light with no delta (its ``incident_radiance`` is what paths see).
    resolution : image side in pixels.
    samples : paths per pixel.
    seed : seed of the paths' random numbers.

    Claims: unbiased; equal to Mitsuba 3's ``volpath`` within noise
    (``benchmarks/bench_bssrdf.py``); Beer–Lambert for an absorbing, index-matched sphere
    (tested).

    References
    ----------
    .. [1] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 3rd ed., §14.5, 2016.

    Examples
    --------
    Under a uniform white sky a sphere that does not absorb (ω = 1) is white: every path leaves
    the sphere and sees radiance 1.

    >>> from brdfkit.light import EnvironmentMap
    >>> sky = EnvironmentMap(np.ones((4, 8, 3)))
    >>> image, stderr = random_walk_sphere(Medium(1.0, 5.0, eta=1.33), sky, 8, 16)
    >>> float(image[4, 4, 0]), float(image[0, 0, 0])  # the centre and a corner (no sphere)
    (1.0, 0.0)
    """
    if light.delta:
        raise ParameterError("light must have no delta (a path can never hit one)")
    resolution = check_count("resolution", resolution, 2048)
    samples = check_count("samples", samples, 1 << 16, minimum=2)
    if resolution * resolution * samples > MAX_PATHS:
        raise ResourceError(
            f"resolution² × samples must be at most {MAX_PATHS:,} paths; got "
            f"{resolution}² × {samples}"
        )
    for name in ("albedo", "sigma_t", "g", "eta"):
        if np.size(getattr(medium, name)) != 1:
            raise ParameterError(f"medium.{name} must be one value (a grey medium)")
    rng = np.random.default_rng(seed)
    pixel = np.repeat(np.arange(resolution * resolution), samples)
    total = np.zeros((pixel.size, light.channels))
    for first in range(0, pixel.size, CHUNK):
        chunk = pixel[first : first + CHUNK]
        total[first : first + chunk.size] = _trace(medium, light, resolution, chunk, rng)
    values = total.reshape(resolution, resolution, samples, -1)
    stderr = values.std(axis=2, ddof=1) / np.sqrt(samples)
    return values.mean(axis=2), stderr


def _trace(
    medium: Medium, light: Light, resolution: int, pixel: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Each path's value, one path per entry of ``pixel`` (flat pixel indices)."""
    row, column = np.divmod(pixel, resolution)
    y = ((column + rng.random(pixel.size)) / resolution) * 2 - 1
    z = 1 - ((row + rng.random(pixel.size)) / resolution) * 2
    value = np.zeros((pixel.size, light.channels))
    hit = np.flatnonzero(y * y + z * z < 1)
    position = np.stack([np.sqrt(1 - y[hit] ** 2 - z[hit] ** 2), y[hit], z[hit]], -1)
    towards_camera = np.broadcast_to([1.0, 0.0, 0.0], position.shape)
    eta = float(medium.eta)
    reflected = rng.random(hit.size) < fresnel_dielectric(position[:, 0], eta)
    mirror = reflect(towards_camera[reflected], position[reflected])
    value[hit[reflected]] = light.incident_radiance(position[reflected], mirror)
    inside = ~reflected
    direction, _ = refract(towards_camera[inside], eta, position[inside])
    _walk(medium, light, hit[inside], position[inside], direction, value, rng)
    return value


def _walk(
    medium: Medium,
    light: Light,
    path: np.ndarray,
    position: np.ndarray,
    direction: np.ndarray,
    value: np.ndarray,
    rng: np.random.Generator,
) -> None:
    """Steps 1–3 of the module docstring for paths just refracted into the sphere; adds each
    leaving path's radiance to ``value[path]``."""
    albedo, sigma_t = float(medium.albedo), float(medium.sigma_t)
    g, eta = float(medium.g), float(medium.eta)
    for _ in range(MAX_EVENTS):
        if path.size == 0:
            return
        b = np.sum(position * direction, -1)
        to_boundary = -b + np.sqrt(np.maximum(b * b - np.sum(position * position, -1) + 1, 0))
        free = -np.log1p(-rng.random(path.size)) / sigma_t
        collides = free < to_boundary
        step = np.where(collides, free, to_boundary)
        position = position + step[:, None] * direction
        absorbed = collides & (rng.random(path.size) >= albedo)
        scatters = collides & ~absorbed
        direction = direction.copy()
        direction[scatters] = _scatter(direction[scatters], g, rng)
        at_boundary = np.flatnonzero(~collides)
        normal = position[at_boundary] / np.linalg.norm(position[at_boundary], axis=-1)[:, None]
        position[at_boundary] = normal  # back onto the sphere, against rounding
        cosine = np.sum(direction[at_boundary] * normal, -1)
        stays = rng.random(at_boundary.size) < fresnel_dielectric(-cosine, eta)
        back = at_boundary[stays]
        direction[back] = reflect(-direction[back], -normal[stays])
        out = at_boundary[~stays]
        leaving, _ = refract(-direction[out], eta, normal[~stays])
        radiance = light.incident_radiance(position[out], leaving)
        np.add.at(value, path[out], radiance)
        keep = ~absorbed
        keep[out] = False
        path, position, direction = path[keep], position[keep], direction[keep]


def _scatter(direction: np.ndarray, g: float, rng: np.random.Generator) -> np.ndarray:
    """New directions after scattering by the Henyey–Greenstein phase function."""
    cos_theta = sample_henyey_greenstein(rng.random(direction.shape[0]), g)
    phi = 2 * np.pi * rng.random(direction.shape[0])
    sin_theta = np.sqrt(np.maximum(1 - cos_theta * cos_theta, 0.0))
    local = np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], -1)
    return to_world(local, frame_from_normal(direction))


__all__ = ["CHUNK", "MAX_EVENTS", "MAX_PATHS", "random_walk_sphere"]
