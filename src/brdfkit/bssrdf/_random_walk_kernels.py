r"""The random walk of :mod:`brdfkit.bssrdf.random_walk` as a numba kernel.

Each function restates, operation by operation in float64, the NumPy code that stays the
reference (``tests/bssrdf/test_random_walk_kernels.py`` holds each pair equal, and the walks of
both equal walk for walk on small inputs):

- ``uniform`` — :func:`brdfkit.bssrdf.random_walk.uniforms`: :math:`u = (h + \tfrac12)\,
  2^{-32}` of the 32-bit hash :func:`brdfkit.sampling.key_hash` of the walk's seed and the
  slot (``key_hash``'s own code, jitted);
- ``fresnel_inside`` — :func:`brdfkit.fresnel.fresnel_dielectric` of light reaching the
  boundary from inside (a negative cosine): the unpolarised reflectance, 1 under total
  internal reflection and at grazing incidence, 0 for a matched index;
- ``scattering_cosine`` — :func:`brdfkit.bssrdf.medium.sample_henyey_greenstein`;
- ``scatter`` — :func:`brdfkit.geometry.frame_from_normal` (Duff et al.'s branchless frame)
  around the direction of travel and the new direction
  :math:`\sin\theta\cos\varphi\,s + \sin\theta\sin\varphi\,t + \cos\theta\,d`;
- :func:`walk_kernel` — ``walk_reference``: one walk after another, the same events drawing
  the same slots.

References
----------
.. [1] T. Duff et al., "Building an orthonormal basis, revisited", JCGT 6(1), 2017.
.. [2] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", 2015.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np

from brdfkit import sampling
from brdfkit.compiled import kernel_tools

SLOTS = 4
"""Uniforms an event of a walk may draw: free path, decision, scattering cosine, azimuth."""

TINY = float(np.finfo(np.float32).tiny)
"""The floor of a squared length before its square root (as :func:`brdfkit._array.normalize`)."""

UNIT = 2.0**-32
"""The spacing of the uniforms: a 32-bit hash h gives :math:`(h + \\tfrac12)\\,2^{-32}`."""


@cache
def kernels() -> dict[str, Callable[..., Any]]:
    """The compiled functions by name (``uniform``, ``fresnel_inside``,
    ``scattering_cosine``, ``scatter``, ``walk``), built once per process."""
    jit = kernel_tools.jit()
    key_hash = jit(
        types.FunctionType(
            sampling.key_hash.__code__, {**vars(sampling), "_mix64": jit(sampling._mix64)}
        )
    )

    @jit
    def uniform(seed: np.uint64, slot: int) -> float:
        return (float(key_hash(seed, np.uint64(slot))) + 0.5) * UNIT

    @jit
    def fresnel_inside(cos_i: float, eta: float) -> float:
        if eta == 1.0:
            return 0.0
        eta_it = 1.0 / eta
        cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * eta * eta
        if cos_t_sqr <= 0.0 or cos_i == 0.0:
            return 1.0
        cos_t = math.sqrt(cos_t_sqr)
        a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t)
        a_p = (eta_it * cos_i - cos_t) / (eta_it * cos_i + cos_t)
        return 0.5 * (a_s * a_s + a_p * a_p)

    @jit
    def scattering_cosine(u: float, g: float) -> float:
        if abs(g) < 1e-3:
            c = 2.0 * u - 1.0
        else:
            ratio = (1.0 - g * g) / (1.0 - g + 2.0 * g * u)
            c = (1.0 + g * g - ratio * ratio) / (2.0 * g)
        return min(max(c, -1.0), 1.0)

    @jit
    def scatter(dx: float, dy: float, dz: float, cos_theta: float, phi: float):
        length = math.sqrt(max(dx * dx + dy * dy + dz * dz, TINY))
        nx, ny, nz = dx / length, dy / length, dz / length
        sign = 1.0 if nz >= 0.0 else -1.0
        a = -1.0 / (sign + nz)
        b = nx * ny * a
        sx, sy, sz = 1.0 + sign * nx * nx * a, sign * b, -sign * nx
        tx, ty, tz = b, sign + ny * ny * a, -ny
        sin_theta = math.sqrt(max(1.0 - cos_theta * cos_theta, 0.0))
        u, v = sin_theta * math.cos(phi), sin_theta * math.sin(phi)
        return (
            u * sx + v * tx + cos_theta * nx,
            u * sy + v * ty + cos_theta * ny,
            u * sz + v * tz + cos_theta * nz,
        )

    @jit
    def one_walk(seed, albedo, eta, g, thickness, dx0, dz0, max_events):
        x, y, z = 0.0, 0.0, 0.0
        dx, dy, dz = dx0, 0.0, dz0
        for k in range(max_events):
            s = -math.log(uniform(seed, SLOTS * k))
            decision = uniform(seed, SLOTS * k + 1)
            if dz < 0.0 and z + s * dz <= 0.0:  # reaches the top boundary
                t = -z / dz
                x, y, z = x + t * dx, y + t * dy, 0.0
                if decision >= fresnel_inside(-dz, eta):
                    return 1, math.sqrt(x * x + y * y), k + 1
                dz = -dz
            elif dz > 0.0 and z + s * dz >= thickness:  # reaches the bottom of a slab
                t = (thickness - z) / dz
                x, y, z = x + t * dx, y + t * dy, thickness
                if decision >= fresnel_inside(dz, eta):
                    return 2, math.sqrt(x * x + y * y), k + 1
                dz = -dz
            else:
                x, y, z = x + s * dx, y + s * dy, z + s * dz
                if decision >= albedo:
                    return 0, math.sqrt(x * x + y * y), k + 1
                cos_theta = scattering_cosine(uniform(seed, SLOTS * k + 2), g)
                phi = 2.0 * math.pi * uniform(seed, SLOTS * k + 3)
                dx, dy, dz = scatter(dx, dy, dz, cos_theta, phi)
        return 3, math.sqrt(x * x + y * y), max_events

    @kernel_tools.exact_jit()
    def walk(seeds, albedo, eta, g, thickness, dx0, dz0, max_events, side, radius, events):
        for i in range(seeds.shape[0]):
            side[i], radius[i], events[i] = one_walk(
                np.uint64(seeds[i]), albedo, eta, g, thickness, dx0, dz0, max_events
            )

    return {
        "uniform": uniform,
        "fresnel_inside": fresnel_inside,
        "scattering_cosine": scattering_cosine,
        "scatter": scatter,
        "walk": walk,
    }


def walk_kernel(
    seeds: np.ndarray,
    albedo: float,
    eta: float,
    g: float,
    thickness: float,
    direction: tuple[float, float],
    max_events: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(side, radius, events)`` of one walk per 64-bit seed: the compiled ``walk_reference``
    of :mod:`brdfkit.bssrdf.random_walk` (the same arguments and results)."""
    n = seeds.shape[0]
    side, radius, events = np.empty(n, np.int8), np.empty(n), np.empty(n, np.int64)
    kernels()["walk"](
        seeds, albedo, eta, g, thickness, direction[0], direction[1], max_events,
        side, radius, events,
    )  # fmt: skip
    return side, radius, events


__all__ = ["SLOTS", "UNIT", "kernels", "walk_kernel"]
