r"""Warps from the unit square to the sphere, disk and triangles, their densities,
piecewise-constant 2D distributions and low-discrepancy points.

Every warp maps uniform variates ``u`` of shape ``(..., 2)`` in :math:`[0, 1)^2` to a point of the
target domain, and comes with a ``*_pdf`` function giving the density of that point with respect to
the target's measure (solid angle for directions, area for the disk and triangle). The names and the
component conventions follow Mitsuba 3's ``warp`` module (``u[..., 0]`` drives the azimuth,
``u[..., 1]`` the polar coordinate), so results agree with ``mitsuba.warp`` sample for sample.

Directions are in the local frame of DESIGN.md (z the normal); all functions run on any array
backend through :mod:`brdfkit._array`, keep the input dtype and let gradients flow from ``u``.
A NumPy ``u`` or ``v`` passed with arrays of another backend (torch vertices, say) computes in
theirs, with their dtype and device.

References
----------
.. [1] P. Shirley and K. Chiu, "A low distortion map between disk and square", Journal of
       Graphics Tools 2(3), 1997.
.. [2] J. Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995.
.. [3] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §A.5 and ch. 13,
       2023.
.. [4] W. Jakob et al., Mitsuba 3, ``include/mitsuba/core/warp.h``, 2022.
.. [5] I. M. Sobol', "On the distribution of points in a cube and the approximate evaluation of
       integrals", USSR Comput. Math. Math. Phys. 7(4), 1967.
"""

from __future__ import annotations

import math
from typing import Any

import array_api_compat
import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    check_finite,
    check_param,
    check_vectors,
    clamp,
    constant,
    cross,
    dot,
    namespace,
    norm,
    normalize,
    safe_div,
    safe_sqrt,
    to_numpy,
)

__all__ = [
    "Distribution2D",
    "hemisphere_pairs",
    "sobol",
    "square_to_cosine_hemisphere",
    "square_to_cosine_hemisphere_pdf",
    "square_to_spherical_triangle",
    "square_to_spherical_triangle_pdf",
    "square_to_uniform_cone",
    "square_to_uniform_cone_pdf",
    "square_to_uniform_disk_concentric",
    "square_to_uniform_disk_concentric_pdf",
    "square_to_uniform_hemisphere",
    "square_to_uniform_hemisphere_pdf",
    "square_to_uniform_sphere",
    "square_to_uniform_sphere_pdf",
    "square_to_uniform_triangle",
    "square_to_uniform_triangle_pdf",
]


# --------------------------------------------------------------------------- validation
def _check_pairs(name: str, v: Array) -> Array:
    """``v`` as a floating array with a last axis of length 2 and finite values."""
    v = asarray(v)
    if v.ndim == 0 or v.shape[-1] != 2:
        raise ValueError(f"{name} must have a last axis of length 2; got shape {tuple(v.shape)}")
    return check_finite(name, v)


def _check_unit_square(name: str, u: Array) -> Array:
    """``u`` validated as points of the closed unit square, shape ``(..., 2)``."""
    return check_param(name, _check_pairs(name, u), 0.0, 1.0, hint="a point of the unit square")


def _in_namespace_of(x: Array, *others: Array | float) -> Array:
    """``x`` converted to the backend of ``others`` (their dtype and device) where they are of
    another one, as a NumPy ``u`` given with torch vertices; otherwise ``x`` unchanged."""
    xp = namespace(x, *others)
    if namespace(x) is xp:
        return x
    like = next(a for a in others if hasattr(a, "dtype") and namespace(a) is xp)
    return asarray(x, xp, like=like)


def _check_cos_cutoff(cos_cutoff: Array | float, like: Array) -> Array:
    """``cos_cutoff`` as an array like ``like``, each value in [-1, 1)."""
    check_param(
        "cos_cutoff",
        cos_cutoff,
        -1.0,
        1.0,
        hi_open=True,
        hint="the cosine of the cone's half-angle",
    )
    return asarray(cos_cutoff, namespace(like, cos_cutoff), like=like)


def _uniform_density(value: Array | float, mask: Array, like: Array) -> Array:
    """``value`` where ``mask`` holds, else 0, broadcast together, a Python scalar taking the
    dtype and device of ``like``."""
    density = value if hasattr(value, "dtype") else constant(value, like)
    xp = namespace(density, mask)
    density = xp.broadcast_to(density, xp.broadcast_shapes(density.shape, mask.shape))
    return xp.where(mask, density, xp.zeros_like(density))


# --------------------------------------------------------------------------- disk
def square_to_uniform_disk_concentric(u: Array) -> Array:
    r"""Shirley–Chiu concentric map of the square onto the unit disk, area-preserving.

    With :math:`(a, b) = 2u - 1`, the square's concentric squares map to the disk's concentric
    circles: for :math:`|a| > |b|`, :math:`r = a,\ \phi = \tfrac{\pi}{4}\, b / a`; otherwise
    :math:`r = b,\ \phi = \tfrac{\pi}{2} - \tfrac{\pi}{4}\, a / b`; the point is
    :math:`r(\cos\phi, \sin\phi)`. Its Jacobian determinant is the constant :math:`\pi/4` (per
    unit of :math:`(a, b)`), so uniform ``u`` gives uniform points, with less distortion than the
    polar map.

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².

    Returns
    -------
    (..., 2) points of the unit disk.

    References
    ----------
    .. [1] P. Shirley and K. Chiu, "A low distortion map between disk and square", JGT 2(3), 1997.
    .. [2] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.1.

    Examples
    --------
    >>> square_to_uniform_disk_concentric([[0.5, 0.5], [0.75, 0.5], [1.0, 0.5]]).tolist()
    [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]
    """
    u = _check_unit_square("u", u)
    xp = namespace(u)
    a = 2 * u[..., 0] - 1
    b = 2 * u[..., 1] - 1
    quadrant_1_or_3 = xp.abs(a) < xp.abs(b)
    r = xp.where(quadrant_1_or_3, b, a)
    r_other = xp.where(quadrant_1_or_3, a, b)
    phi = (math.pi / 4) * safe_div(r_other, r)
    phi = xp.where(quadrant_1_or_3, math.pi / 2 - phi, phi)
    return xp.stack([r * xp.cos(phi), r * xp.sin(phi)], axis=-1)


def square_to_uniform_disk_concentric_pdf(p: Array) -> Array:
    r"""Area density of :func:`square_to_uniform_disk_concentric`: :math:`1/\pi` on the unit disk,
    0 outside.

    Parameters
    ----------
    p : (..., 2) points of the plane.

    Returns
    -------
    (...,) density per unit area.

    References
    ----------
    .. [1] P. Shirley and K. Chiu, "A low distortion map between disk and square", JGT 2(3), 1997.

    Examples
    --------
    >>> square_to_uniform_disk_concentric_pdf([[0.5, 0.0], [1.0, 1.0]]).round(4).tolist()
    [0.3183, 0.0]
    """
    p = _check_pairs("p", p)
    return _uniform_density(1 / math.pi, dot(p, p) <= 1, p)


# --------------------------------------------------------------------------- sphere, hemisphere
def square_to_uniform_sphere(u: Array) -> Array:
    r"""Uniform directions on the unit sphere: :math:`z = 1 - 2u_1,\ \phi = 2\pi u_0`.

    By Archimedes' hat-box theorem the band :math:`dz` has area :math:`2\pi\,dz`, so linear ``z``
    is uniform in solid angle.

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².

    Returns
    -------
    (..., 3) unit directions.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.2.

    Examples
    --------
    >>> square_to_uniform_sphere([0.0, 0.25]).round(4).tolist()
    [0.866, 0.0, 0.5]
    >>> float(square_to_uniform_sphere_pdf([0.0, 0.0, -1.0]).round(6))  # 1/(4π)
    0.079577
    """
    u = _check_unit_square("u", u)
    xp = namespace(u)
    z = 1 - 2 * u[..., 1]
    r = safe_sqrt(1 - z * z)
    phi = (2 * math.pi) * u[..., 0]
    return xp.stack([r * xp.cos(phi), r * xp.sin(phi), z], axis=-1)


def square_to_uniform_sphere_pdf(v: Array) -> Array:
    r"""Solid-angle density of :func:`square_to_uniform_sphere`: :math:`1/(4\pi)`.

    Parameters
    ----------
    v : (..., 3) directions.

    Returns
    -------
    (...,) density per steradian.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.2.
    """
    v = check_vectors("v", v)
    xp = namespace(v)
    return _uniform_density(1 / (4 * math.pi), xp.ones_like(v[..., 2], dtype=xp.bool), v)


def square_to_uniform_hemisphere(u: Array) -> Array:
    r"""Uniform directions on the upper hemisphere (z ≥ 0), through the concentric disk.

    With :math:`p` the concentric disk point of ``u`` (:func:`square_to_uniform_disk_concentric`),
    :math:`z = 1 - |p|^2` and :math:`(x, y) = p\sqrt{1 + z}` (Lambert's azimuthal equal-area
    projection), which is uniform in solid angle and less distorted than :math:`z = u_1`.

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².

    Returns
    -------
    (..., 3) unit directions with z ≥ 0.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``warp::square_to_uniform_hemisphere``, 2022.
    .. [2] P. Shirley and K. Chiu, "A low distortion map between disk and square", JGT 2(3), 1997.

    Examples
    --------
    >>> square_to_uniform_hemisphere([0.5, 0.5]).tolist()
    [0.0, 0.0, 1.0]
    >>> up_and_down = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]
    >>> square_to_uniform_hemisphere_pdf(up_and_down).round(4).tolist()  # 1/(2π), then 0
    [0.1592, 0.0]
    """
    p = square_to_uniform_disk_concentric(u)
    xp = namespace(p)
    z = 1 - dot(p, p)
    p = p * xp.sqrt(z + 1)[..., None]
    return xp.concat([p, z[..., None]], axis=-1)


def square_to_uniform_hemisphere_pdf(v: Array) -> Array:
    r"""Solid-angle density of :func:`square_to_uniform_hemisphere`: :math:`1/(2\pi)` for
    :math:`z \ge 0`, 0 below the surface.

    Parameters
    ----------
    v : (..., 3) directions.

    Returns
    -------
    (...,) density per steradian.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.2.
    """
    v = check_vectors("v", v)
    return _uniform_density(1 / (2 * math.pi), v[..., 2] >= 0, v)


def hemisphere_pairs(count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``count`` independent random direction pairs ``(wi, wo)``, NumPy float64 ``(count, 3)``
    each, uniform on the upper hemisphere (:func:`square_to_uniform_hemisphere`; ``wi`` drawn
    first, from one NumPy generator seeded with ``seed``): the usual arguments of a check or a
    fit of a BRDF.

    Examples
    --------
    >>> wi, wo = hemisphere_pairs(1000, seed=1)
    >>> wi.shape, bool((wi[:, 2] >= 0).all() and (wo[:, 2] >= 0).all())
    ((1000, 3), True)
    """
    rng = np.random.default_rng(seed)
    return (
        square_to_uniform_hemisphere(rng.random((count, 2))),
        square_to_uniform_hemisphere(rng.random((count, 2))),
    )


def square_to_cosine_hemisphere(u: Array) -> Array:
    r"""Cosine-weighted directions on the upper hemisphere by Malley's method.

    A uniform point :math:`p` of the unit disk (concentric map) is lifted to the hemisphere,
    :math:`\omega = (p_x, p_y, \sqrt{1 - |p|^2})`; projecting solid angle onto the disk multiplies
    it by :math:`\cos\theta`, so the density is :math:`\cos\theta / \pi`.

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².

    Returns
    -------
    (..., 3) unit directions with z ≥ 0.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.3 (Malley's method).
    .. [2] P. Shirley and K. Chiu, "A low distortion map between disk and square", JGT 2(3), 1997.

    Examples
    --------
    The centre of the square goes to the normal; the density is cos θ/π
    (:func:`square_to_cosine_hemisphere_pdf`):

    >>> w = square_to_cosine_hemisphere([[0.5, 0.5], [0.25, 0.5]])
    >>> w.round(4).tolist()
    [[0.0, 0.0, 1.0], [-0.5, 0.0, 0.866]]
    >>> square_to_cosine_hemisphere_pdf(w).round(4).tolist()
    [0.3183, 0.2757]
    """
    p = square_to_uniform_disk_concentric(u)
    xp = namespace(p)
    z = safe_sqrt(1 - dot(p, p))
    return xp.concat([p, z[..., None]], axis=-1)


def square_to_cosine_hemisphere_pdf(v: Array) -> Array:
    r"""Solid-angle density of :func:`square_to_cosine_hemisphere`:
    :math:`\max(\cos\theta, 0)/\pi`.

    Parameters
    ----------
    v : (..., 3) unit directions.

    Returns
    -------
    (...,) density per steradian.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.3.
    """
    v = check_vectors("v", v)
    return clamp(v[..., 2], 0.0) / math.pi


def square_to_uniform_cone(u: Array, cos_cutoff: Array | float) -> Array:
    r"""Uniform directions in the cone :math:`\cos\theta \ge \cos\theta_{max}` about +z.

    With :math:`p` the concentric disk point of ``u`` and :math:`k = 1 - \cos\theta_{max}`,
    :math:`z = 1 - k|p|^2` and :math:`(x, y) = p\sqrt{k(2 - k|p|^2)}`: the cap area above ``z`` is
    linear in :math:`|p|^2`, hence uniform in solid angle.

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².
    cos_cutoff : cosine of the cone's half-angle, in [-1, 1); broadcasts against ``u[..., 0]``.

    Returns
    -------
    (..., 3) unit directions.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``warp::square_to_uniform_cone``, 2022.
    .. [2] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.4.

    Examples
    --------
    The rim of the square goes to the rim of the cone (here θ_max = 60°), where the density is
    1/(2π(1 − cos θ_max)) = 1/π:

    >>> w = square_to_uniform_cone([1.0, 0.5], 0.5)
    >>> float(w[2].round(4))
    0.5
    >>> float(square_to_uniform_cone_pdf(w, 0.5).round(4))
    0.3183
    """
    p = square_to_uniform_disk_concentric(_in_namespace_of(u, cos_cutoff))
    xp = namespace(p, cos_cutoff)
    one_minus_cos = 1 - _check_cos_cutoff(cos_cutoff, p)
    r2 = dot(p, p)
    scale = safe_sqrt(one_minus_cos * (2 - one_minus_cos * r2))
    z = 1 - one_minus_cos * r2
    return xp.stack([p[..., 0] * scale, p[..., 1] * scale, z], axis=-1)


def square_to_uniform_cone_pdf(v: Array, cos_cutoff: Array | float) -> Array:
    r"""Solid-angle density of :func:`square_to_uniform_cone`:
    :math:`1 / (2\pi(1 - \cos\theta_{max}))` inside the cone, 0 outside.

    Parameters
    ----------
    v : (..., 3) unit directions.
    cos_cutoff : cosine of the cone's half-angle, in [-1, 1).

    Returns
    -------
    (...,) density per steradian.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.5.4.
    """
    v = check_vectors("v", _in_namespace_of(v, cos_cutoff))
    cos_cutoff = _check_cos_cutoff(cos_cutoff, v)
    return _uniform_density(1 / (2 * math.pi * (1 - cos_cutoff)), v[..., 2] >= cos_cutoff, v)


# --------------------------------------------------------------------------- triangles
def square_to_uniform_triangle(u: Array) -> Array:
    r"""Uniform barycentric coordinates on a triangle: :math:`t = \sqrt{1 - u_0}`,
    :math:`(b_1, b_2) = (1 - t,\ t\,u_1)`.

    The point is :math:`(1 - b_1 - b_2)\,a + b_1\,b + b_2\,c` for vertices :math:`a, b, c`
    (Mitsuba's convention).

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².

    Returns
    -------
    (..., 2) barycentrics :math:`(b_1, b_2)` with :math:`b_1, b_2 \ge 0,\ b_1 + b_2 \le 1`.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 3rd ed., §13.6.5.
    .. [2] W. Jakob et al., Mitsuba 3, ``warp::square_to_uniform_triangle``, 2022.

    Examples
    --------
    >>> b = square_to_uniform_triangle([0.19, 0.5])
    >>> b.round(4).tolist(), float(square_to_uniform_triangle_pdf(b))
    ([0.1, 0.45], 2.0)
    """
    u = _check_unit_square("u", u)
    xp = namespace(u)
    t = safe_sqrt(1 - u[..., 0])
    return xp.stack([1 - t, t * u[..., 1]], axis=-1)


def square_to_uniform_triangle_pdf(p: Array) -> Array:
    r"""Density of :func:`square_to_uniform_triangle` in the barycentric plane: 2 on the triangle
    :math:`b_1, b_2 \ge 0,\ b_1 + b_2 \le 1` (of area 1/2), 0 outside.

    Parameters
    ----------
    p : (..., 2) barycentrics :math:`(b_1, b_2)`.

    Returns
    -------
    (...,) density per unit barycentric area.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``warp::square_to_uniform_triangle_pdf``, 2022.
    """
    p = _check_pairs("p", p)
    inside = (p[..., 0] >= 0) & (p[..., 1] >= 0) & (p[..., 0] + p[..., 1] <= 1)
    return _uniform_density(2.0, inside, p)


def _angle_between(v1: Array, v2: Array) -> Array:
    """Angle between unit vectors, accurate near 0 and π (PBRT's ``AngleBetween``)."""
    xp = namespace(v1, v2)
    near = 2 * xp.asin(clamp(norm(v2 - v1) / 2, hi=1.0))
    far = math.pi - 2 * xp.asin(clamp(norm(v1 + v2) / 2, hi=1.0))
    return xp.where(dot(v1, v2) < 0, far, near)


def _spherical_triangle(
    a: Array, b: Array, c: Array, like: Array
) -> tuple[Array, Array, Array, Array, Array, Array]:
    """Normalised vertices, the inward normals of the edge planes, the vertex angle at ``a``
    and the solid angle of the spherical triangle ``abc``."""
    xp = namespace(like, a, b, c)
    a, b, c = (
        normalize(check_vectors(name, asarray(v, xp, like=like)))
        for name, v in (("a", a), ("b", b), ("c", c))
    )
    n_ab, n_bc, n_ca = normalize(cross(a, b)), normalize(cross(b, c)), normalize(cross(c, a))
    alpha = _angle_between(n_ab, -n_ca)
    beta = _angle_between(n_bc, -n_ab)
    gamma = _angle_between(n_ca, -n_bc)
    solid_angle = alpha + beta + gamma - math.pi
    degenerate = (norm(n_ab) == 0) | (norm(n_bc) == 0) | (norm(n_ca) == 0) | (solid_angle <= 0)
    if bool(xp.any(degenerate)):
        raise ValueError(
            "a, b, c must span a spherical triangle of positive solid angle; got collinear or "
            "coincident vertices"
        )
    orientation = xp.sign(dot(a, cross(b, c)))
    return (
        a,
        b,
        c,
        orientation[..., None, None] * xp.stack([n_ab, n_bc, n_ca], axis=-2),
        alpha,
        solid_angle,
    )


def square_to_spherical_triangle(u: Array, a: Array, b: Array, c: Array) -> Array:
    r"""Uniform directions on the spherical triangle with vertices ``a``, ``b``, ``c`` (Arvo 1995).

    :math:`u_0` picks the sub-triangle :math:`a\,b\,\hat c` of area :math:`A' = u_0 A`, where
    :math:`A = \alpha + \beta + \gamma - \pi` is the solid angle; :math:`\hat c` on the arc
    :math:`ac` follows in closed form from the spherical law of cosines,
    :math:`\cos\hat b = \frac{k_2 + (k_2\cos\phi - k_1\sin\phi)\cos\alpha}
    {(k_2\sin\phi + k_1\cos\phi)\sin\alpha}` with :math:`\phi = A' - \alpha`,
    :math:`k_1 = \cos\phi + \cos\alpha`, :math:`k_2 = \sin\phi - \sin\alpha\,(a\cdot b)`; then
    :math:`u_1` picks :math:`\cos\theta = 1 - u_1(1 - \hat c\cdot b)` along the arc from ``b``
    towards :math:`\hat c`. The density is :math:`1/A`.

    Parameters
    ----------
    u : (..., 2) uniform variates in [0, 1)².
    a, b, c : (..., 3) vertex directions (normalised here), broadcasting against ``u[..., 0]``.

    Returns
    -------
    (..., 3) unit directions inside the triangle.

    References
    ----------
    .. [1] J. Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995.
    .. [2] M. Pharr et al., *Physically Based Rendering*, 4th ed., §6.5.4 (the robust form used).

    Examples
    --------
    The octant spanned by the axes has solid angle π/2:

    >>> import numpy as np
    >>> a, b, c = np.eye(3)
    >>> w = square_to_spherical_triangle([0.3, 0.7], a, b, c)
    >>> bool(np.all(w > 0)), float(np.linalg.norm(w).round(12))
    (True, 1.0)
    >>> float((square_to_spherical_triangle_pdf(w, a, b, c) * np.pi / 2).round(12))
    1.0
    """
    u = _check_unit_square("u", _in_namespace_of(u, a, b, c))
    a, b, c, _, alpha, solid_angle = _spherical_triangle(a, b, c, u)
    xp = namespace(u, a)
    area_pi = u[..., 0] * solid_angle + math.pi  # A' + π, so that φ = A' − α = (A' + π) − α − π
    cos_alpha, sin_alpha = xp.cos(alpha), xp.sin(alpha)
    sin_phi = xp.sin(area_pi) * cos_alpha - xp.cos(area_pi) * sin_alpha
    cos_phi = xp.cos(area_pi) * cos_alpha + xp.sin(area_pi) * sin_alpha
    k1 = cos_phi + cos_alpha
    k2 = sin_phi - sin_alpha * dot(a, b)
    cos_b_hat = safe_div(
        k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha, (k2 * sin_phi + k1 * cos_phi) * sin_alpha
    )
    cos_b_hat = clamp(cos_b_hat, -1.0, 1.0)
    c_perp = normalize(c - dot(c, a, keepdims=True) * a)
    c_hat = cos_b_hat[..., None] * a + safe_sqrt(1 - cos_b_hat * cos_b_hat)[..., None] * c_perp
    cos_theta = 1 - u[..., 1] * (1 - dot(c_hat, b))
    sin_theta = safe_sqrt(1 - cos_theta * cos_theta)
    c_hat_perp = normalize(c_hat - dot(c_hat, b, keepdims=True) * b)
    return cos_theta[..., None] * b + sin_theta[..., None] * c_hat_perp


def square_to_spherical_triangle_pdf(v: Array, a: Array, b: Array, c: Array) -> Array:
    r"""Solid-angle density of :func:`square_to_spherical_triangle`: :math:`1/\Omega` inside the
    triangle, 0 outside, with :math:`\Omega = \alpha + \beta + \gamma - \pi` (Girard's theorem).

    Parameters
    ----------
    v : (..., 3) directions.
    a, b, c : (..., 3) vertex directions.

    Returns
    -------
    (...,) density per steradian.

    References
    ----------
    .. [1] J. Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995.
    """
    v = check_vectors("v", _in_namespace_of(v, a, b, c))
    xp = namespace(v, a, b, c)
    _, _, _, normals, _, solid_angle = _spherical_triangle(a, b, c, v)
    inside = xp.all(xp.sum(v[..., None, :] * normals, axis=-1) >= 0, axis=-1)
    return _uniform_density(1 / solid_angle, inside, v)


# --------------------------------------------------------------------------- 2D distributions
def _find_interval(cdf: Array, base: Array, u: Array, count: int) -> Array:
    """Per sample, ``k`` in ``[0, count)`` with ``cdf[base + k] <= u < cdf[base + k + 1]``.

    A vectorised bisection on the flat table ``cdf`` (rows of ``count + 1`` entries starting at
    ``base``); it only needs ``take``, so it works on every backend and for many rows at once.
    """
    xp = namespace(cdf, u)
    lo = xp.zeros_like(base)
    hi = xp.full_like(base, count)
    for _ in range(max(1, math.ceil(math.log2(count))) + 1):
        mid = (lo + hi) // 2
        right = xp.take(cdf, base + mid) <= u
        lo = xp.where(right, mid, lo)
        hi = xp.where(right, hi, mid)
    return lo


class Distribution2D:
    r"""A piecewise-constant distribution on :math:`[0, 1)^2` proportional to an image.

    Texel ``f[i, j]`` (row ``i`` along y, column ``j`` along x) covers
    :math:`[j/W, (j+1)/W) \times [i/H, (i+1)/H)`; the density w.r.t. the unit square is
    :math:`p(x, y) = f_{ij} / \bar f` with :math:`\bar f` the image mean. Sampling inverts the
    marginal CDF over rows with :math:`u_1` and then the row's conditional CDF over columns with
    :math:`u_0`, linearly inside the texel, so :meth:`invert` is its exact inverse. For an
    environment map pass luminance·sin θ and convert the density to solid angle with
    :math:`p_\omega = p / (2\pi^2 \sin\theta)`.

    The tables are built once in float64 NumPy from ``image`` (a constant: no gradient flows to
    it); :meth:`sample`, :meth:`pdf` and :meth:`invert` run in the namespace of their argument and
    return its dtype, with gradients flowing from ``u`` to the points.

    Parameters
    ----------
    image : (H, W) non-negative finite values, not all zero (any backend).

    Attributes
    ----------
    shape : (H, W).
    integral : :math:`\bar f`, the integral of the image over the unit square.
    density : (H, W) float64 NumPy array, :math:`f / \bar f`.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §A.4.2 (``PiecewiseConstant2D``).
    .. [2] W. Jakob et al., Mitsuba 3, ``DiscreteDistribution2D``, 2022.

    Examples
    --------
    A one-row image whose right texel is three times as bright as the left one:

    >>> import numpy as np
    >>> distribution = Distribution2D(np.array([[1.0, 3.0]]))
    >>> points, pdf = distribution.sample(np.array([[0.1, 0.5], [0.5, 0.5]]))
    >>> points.round(4).tolist(), pdf.tolist()
    ([[0.2, 0.5], [0.6667, 0.5]], [0.5, 1.5])
    >>> distribution.invert(points).round(4).tolist()
    [[0.1, 0.5], [0.5, 0.5]]
    """

    def __init__(self, image: Any) -> None:
        f = np.asarray(to_numpy(image), dtype=np.float64)  # read only: no copy needed
        if f.ndim != 2 or f.size == 0:
            raise ValueError(f"image must be a non-empty 2D array (H, W); got shape {f.shape}")
        low, high = f.min(), f.max()  # NaN in either where f holds one
        if not (low >= 0 and high < np.inf):
            check_param("image", f, 0.0)  # raises, naming the offending value
        if not high > 0:
            raise ValueError("image must have a positive value somewhere; got all zeros")
        height, width = f.shape
        self.shape: tuple[int, int] = (height, width)
        self.integral: float = float(f.mean())
        self.density: np.ndarray = f / self.integral
        row_sums = f.sum(axis=1)
        marginal = np.concatenate([[0.0], np.cumsum(row_sums)]) / row_sums.sum()
        marginal[-1] = 1.0
        conditional = np.zeros((height, width + 1))
        np.cumsum(f, axis=1, out=conditional[:, 1:])
        # A row of zeros is never sampled; it gets a uniform CDF so that invert() stays defined.
        empty = row_sums == 0
        conditional[empty] = np.arange(width + 1)
        conditional /= conditional[:, -1:]
        conditional[:, -1] = 1.0
        self._marginal = marginal
        self._conditional = conditional.ravel()

    def _tables(self, like: Array) -> tuple[Array, Array, Array]:
        """The marginal CDF, flat conditional CDFs and flat density in the namespace of ``like``."""
        xp = namespace(like)
        device = array_api_compat.device(like)
        return tuple(
            xp.asarray(t, dtype=xp.float64, device=device)
            for t in (self._marginal, self._conditional, self.density.ravel())
        )

    def sample(self, u: Array) -> tuple[Array, Array]:
        r"""Points distributed as the image, and their density w.r.t. the unit square.

        Parameters
        ----------
        u : (..., 2) uniform variates in [0, 1)²; :math:`u_1` picks the row (y),
            :math:`u_0` the column (x).

        Returns
        -------
        points : (..., 2) in [0, 1)², ``(x, y)``.
        pdf : (...,) :math:`f_{ij}/\bar f` at the points.
        """
        u = _check_unit_square("u", u)
        xp = namespace(u)
        height, width = self.shape
        marginal, conditional, density = self._tables(u)
        # Flat batch (``take`` needs 1-D indices); float64 so that the CDFs are resolved exactly.
        u64 = xp.reshape(xp.astype(u, xp.float64), (-1, 2))
        u64 = xp.minimum(u64, constant(1 - xp.finfo(xp.float64).eps / 2, u64))
        u0, u1 = u64[:, 0], u64[:, 1]
        zero = xp.zeros(u1.shape, dtype=xp.int64, device=array_api_compat.device(u))
        row = _find_interval(marginal, zero, u1, height)
        base = row * (width + 1)
        col = _find_interval(conditional, base, u0, width)
        m0, m1 = xp.take(marginal, row), xp.take(marginal, row + 1)
        c0, c1 = xp.take(conditional, base + col), xp.take(conditional, base + col + 1)
        x = (xp.astype(col, xp.float64) + (u0 - c0) / (c1 - c0)) / width
        y = (xp.astype(row, xp.float64) + (u1 - m0) / (m1 - m0)) / height
        points = xp.astype(xp.stack([x, y], axis=-1), u.dtype)
        # Rounding (to float32 especially) may reach 1.0: keep the points inside [0, 1).
        points = xp.minimum(points, constant(1 - xp.finfo(u.dtype).eps / 2, points))
        pdf = xp.take(density, row * width + col)
        points = xp.reshape(points, u.shape)
        pdf = xp.reshape(xp.astype(pdf, u.dtype), u.shape[:-1])
        return points, pdf

    def _cells(self, points: Array) -> tuple[Array, Array, Array, Array]:
        """Row and column of each point of the flattened batch (clipped into the grid) and the
        offsets inside the texel, in float64."""
        xp = namespace(points)
        height, width = self.shape
        p64 = xp.reshape(xp.astype(points, xp.float64), (-1, 2))
        x, y = p64[:, 0] * width, p64[:, 1] * height
        col = xp.astype(xp.clip(xp.floor(x), 0, width - 1), xp.int64)
        row = xp.astype(xp.clip(xp.floor(y), 0, height - 1), xp.int64)
        return row, col, x - xp.astype(col, xp.float64), y - xp.astype(row, xp.float64)

    def pdf(self, points: Array) -> Array:
        r"""Density :math:`f_{ij}/\bar f` of :meth:`sample` at ``points`` (0 outside [0, 1)²).

        Parameters
        ----------
        points : (..., 2) ``(x, y)``.

        Returns
        -------
        (...,) density w.r.t. the unit square.
        """
        points = _check_pairs("points", points)
        xp = namespace(points)
        _, _, density = self._tables(points)
        row, col, _, _ = self._cells(points)
        value = xp.reshape(xp.take(density, row * self.shape[1] + col), points.shape[:-1])
        value = xp.astype(value, points.dtype)
        inside = xp.all((points >= 0) & (points < 1), axis=-1)
        return xp.where(inside, value, xp.zeros_like(value))

    def invert(self, points: Array) -> Array:
        r"""The variates ``u`` that :meth:`sample` maps to ``points``: the CDFs evaluated there.

        :math:`u_1 = P(i) + (yH - i)\,p(i)` and :math:`u_0 = P_i(j) + (xW - j)\,p_i(j)`, with
        :math:`P, p` the cumulative and discrete probabilities of the marginal over rows and
        :math:`P_i, p_i` those of row ``i``'s conditional distribution over columns.

        Parameters
        ----------
        points : (..., 2) ``(x, y)`` in [0, 1]².

        Returns
        -------
        (..., 2) variates in [0, 1]².
        """
        points = _check_unit_square("points", points)
        xp = namespace(points)
        marginal, conditional, _ = self._tables(points)
        row, col, du, dv = self._cells(points)
        m0, m1 = xp.take(marginal, row), xp.take(marginal, row + 1)
        flat = row * (self.shape[1] + 1) + col
        c0, c1 = xp.take(conditional, flat), xp.take(conditional, flat + 1)
        u = xp.stack([c0 + du * (c1 - c0), m0 + dv * (m1 - m0)], axis=-1)
        return xp.reshape(xp.astype(u, points.dtype), points.shape)


# --------------------------------------------------------------------------- low discrepancy
def sobol(n: int, dim: int, seed: int | None = None, scramble: bool = True) -> np.ndarray:
    r"""The first ``n`` points of the ``dim``-dimensional Sobol' sequence in :math:`[0, 1)^{dim}`.

    A thin wrapper over :class:`scipy.stats.qmc.Sobol` (direction numbers of Joe and Kuo) that
    returns a float64 NumPy array; convert it to another backend with
    ``brdfkit._array.asarray(points, xp)``. Owen scrambling (``scramble=True``, the default) makes
    every point uniformly distributed while keeping the low discrepancy, so estimates are unbiased
    and ``seed`` gives independent replicates. Powers of two keep the balance properties (SciPy
    warns otherwise).

    Parameters
    ----------
    n : number of points, ≥ 1.
    dim : dimension, in [1, 21201].
    seed : seed of the scrambling (ignored without ``scramble``).
    scramble : whether to apply Owen-type scrambling.

    Returns
    -------
    (n, dim) float64 array.

    References
    ----------
    .. [1] I. M. Sobol', USSR Comput. Math. Math. Phys. 7(4), 1967.
    .. [2] S. Joe and F. Y. Kuo, "Constructing Sobol sequences with better two-dimensional
           projections", SIAM J. Sci. Comput. 30, 2008.

    Examples
    --------
    >>> sobol(4, 2, scramble=False).tolist()
    [[0.0, 0.0], [0.5, 0.5], [0.75, 0.25], [0.25, 0.75]]
    >>> sobol(256, 3, seed=7).shape
    (256, 3)
    """
    from scipy.stats import qmc

    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise ValueError(f"n must be a positive integer; got {n!r}")
    if isinstance(dim, bool) or not isinstance(dim, int | np.integer) or not 1 <= dim <= 21201:
        raise ValueError(f"dim must be an integer in [1, 21201]; got {dim!r}")
    return qmc.Sobol(int(dim), scramble=scramble, seed=seed).random(int(n))


# Sobol' generator matrices, one column per bit of the index (column j: the point of index
# 2^j), as 32-bit integers whose most significant bit is the first binary digit. Dimension 1
# is van der Corput's; the others follow Joe and Kuo's ``new-joe-kuo-6.21201`` primitive
# polynomials (degree s, coefficients a) and initial direction numbers m.
_JOE_KUO = ((1, 0, (1,)), (2, 1, (1, 3)), (3, 1, (1, 3, 1)), (3, 2, (1, 1, 1)))
SOBOL_BITS = 32


def _sobol_matrices() -> np.ndarray:
    """``(1 + len(_JOE_KUO), 32)`` uint32 generator columns (Bratley–Fox recurrence)."""
    columns = [[1 << (SOBOL_BITS - 1 - j) for j in range(SOBOL_BITS)]]
    for s, a, m in _JOE_KUO:
        v = [m[k] << (SOBOL_BITS - 1 - k) for k in range(s)]
        for k in range(s, SOBOL_BITS):
            value = v[k - s] ^ (v[k - s] >> s)
            for i in range(1, s):
                if (a >> (s - 1 - i)) & 1:
                    value ^= v[k - i]
            v.append(value)
        columns.append(v)
    return np.array(columns, dtype=np.uint32)


SOBOL_MATRICES = _sobol_matrices()
"""Generator columns of the first :data:`SOBOL_DIMENSIONS` Sobol' dimensions, ``(d, 32)``."""
SOBOL_DIMENSIONS = SOBOL_MATRICES.shape[0]


def sobol_integers(first: int, n: int, dim: int) -> np.ndarray:
    r"""Points ``first`` … ``first + n − 1`` of the unscrambled Sobol' sequence (natural, not
    Gray-code, order) as 32-bit integers :math:`x = 2^{32} u`, ``(n, dim)`` uint32: the XOR of
    the generator columns of the index's set bits. Every aligned block of :math:`2^m` indices
    (the first :math:`2^m`, the next :math:`2^m`, …) is a (t, m, s)-net in base 2."""
    if not 1 <= dim <= SOBOL_DIMENSIONS:
        raise ValueError(f"dim must be in [1, {SOBOL_DIMENSIONS}]; got {dim}")
    if first < 0 or n < 0 or first + n > 1 << SOBOL_BITS:
        raise ValueError(f"indices must lie in [0, 2^32); got first={first}, n={n}")
    index = np.arange(first, first + n, dtype=np.uint64)
    bits = ((index[:, None] >> np.arange(SOBOL_BITS, dtype=np.uint64)) & 1).astype(bool)
    terms = np.where(bits[:, None, :], SOBOL_MATRICES[None, :dim, :], np.uint32(0))
    return np.bitwise_xor.reduce(terms, axis=-1)


_U32 = np.uint32
_MASK = _U32(0xFFFFFFFF)
_ONE, _TWO, _FOUR, _EIGHT, _SIXTEEN = _U32(1), _U32(2), _U32(4), _U32(8), _U32(16)
_M1, _M2, _M4, _M8 = _U32(0x55555555), _U32(0x33333333), _U32(0x0F0F0F0F), _U32(0x00FF00FF)
_LK = _U32(0x3D20ADEA), _U32(0x05526C56), _U32(0x53A22864)
# The bit operations below run on NumPy uint32 arrays and, unchanged, on numba uint64 scalars
# (the compiled tile kernel, brdfkit.render._reflection_kernels): every constant is a uint32
# (never a Python int, which numba types as int64 and would mix into float64) and every product
# is masked to 32 bits.


def reverse_bits(x: Any) -> Any:
    """The 32 bits of ``x`` in reverse order (NumPy uint32 arrays, or uint64 scalars in numba:
    the same code, results below 2^32)."""
    x = ((x >> _ONE) & _M1) | ((x & _M1) << _ONE)
    x = ((x >> _TWO) & _M2) | ((x & _M2) << _TWO)
    x = ((x >> _FOUR) & _M4) | ((x & _M4) << _FOUR)
    x = ((x >> _EIGHT) & _M8) | ((x & _M8) << _EIGHT)
    return ((x >> _SIXTEEN) | (x << _SIXTEEN)) & _MASK


def nested_scramble(x: Any, seed: Any) -> Any:
    r"""A hash-based nested uniform (Owen) scramble of the 32-bit digits ``x`` with ``seed``.

    In bit-reversed order every step (adding the seed, multiplying by an odd number, XOR with
    a multiple by an even number) changes each bit by a function of the bits below it only,
    so in natural order each binary digit of ``x`` is flipped by a function of the digits
    before it: a nested scramble, which maps every (t, m, s)-net to a (t, m, s)-net. The
    hash is Vegdahl's improvement of Laine and Karras's. NumPy uint32 arrays, or uint64
    scalars in numba (the same code: every product is masked to 32 bits).

    References
    ----------
    .. [1] S. Laine, T. Karras, "Stratified sampling for stochastic transparency", EGSR 2011.
    .. [2] B. Burley, "Practical hash-based Owen scrambling", JCGT 9(4), 2020.
    .. [3] N. Vegdahl, "Building a better LK hash", psychopath.io, 2021.
    """
    return reverse_bits(laine_karras(reverse_bits(x), seed))


def laine_karras(x: Any, seed: Any) -> Any:
    """The hash of :func:`nested_scramble` on bit-reversed digits: each output bit depends on
    the input bits at and below it only."""
    x = x ^ ((x * _LK[0]) & _MASK)
    x = (x + seed) & _MASK
    x = (x * ((seed >> _SIXTEEN) | _ONE)) & _MASK
    x = x ^ ((x * _LK[1]) & _MASK)
    return x ^ ((x * _LK[2]) & _MASK)


def scrambled_sobol(first: int, n: int, keys: np.ndarray) -> np.ndarray:
    r"""Points ``first`` … ``first + n − 1`` of the Sobol' sequence, independently scrambled per
    query: ``keys`` ``(..., 2, dim)`` uint32 (per dimension a scramble seed, then a digital
    shift) give ``(..., n, dim)`` float64 variates

    .. math:: u = 2^{-32}\bigl(\mathrm{scramble}(x_i, s) \oplus t\bigr),

    :func:`nested_scramble` of the sequence's digits :math:`x_i` (:func:`sobol_integers`)
    followed by the random digital shift t. With uniform random t each point is uniform on
    the grid of :math:`2^{-32}` (estimates unbiased), and each aligned block of :math:`2^m`
    indices of each query stays a (t, m, s)-net, so successive blocks (``first`` 0, then n,
    2n, … with the same keys) refine one net.

    References
    ----------
    .. [1] A. B. Owen, "Randomly permuted (t, m, s)-nets and (t, s)-sequences", 1995.
    .. [2] B. Burley, "Practical hash-based Owen scrambling", JCGT 9(4), 2020.
    """
    keys = np.asarray(keys, dtype=np.uint32)
    points = sobol_integers(first, n, keys.shape[-1])
    x = nested_scramble(points, keys[..., None, 0, :]) ^ keys[..., None, 1, :]
    return x * 2.0**-SOBOL_BITS


def _mix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser: a bijective 64-bit hash (uint64 arrays, wrapping)."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def query_seeds(seed: int, count: int, first: int = 0) -> np.ndarray:
    """Per-query 64-bit seeds ``(count,)`` uint64 of queries ``first`` … ``first + count − 1``
    under ``seed``: a hash of (seed, index), so that a query's seed depends on its index
    alone, not on how the queries are batched."""
    root = _mix64(np.array([seed & 0xFFFFFFFFFFFFFFFF], dtype=np.uint64) + np.uint64(1))
    index = np.arange(first, first + count, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)
    return _mix64(index ^ root)


def scramble_keys(seeds: np.ndarray, stream: int, dim: int) -> np.ndarray:
    """The :func:`scrambled_sobol` keys ``(..., 2, dim)`` uint32 of each query's 64-bit seed
    ``(...,)`` for its ``stream``-th independent point set: hashes of (seed, stream, slot)."""
    seeds = np.asarray(seeds, dtype=np.uint64)
    slots = np.arange(2 * dim, dtype=np.uint64) + key_slot(stream, 0)
    return key_hash(seeds[..., None], slots).astype(np.uint32).reshape(*seeds.shape, 2, dim)


def key_slot(stream: int, slot: int) -> np.uint64:
    """The hash input of slot ``slot`` (``i · dim + k``: key i of dimension k) of stream
    ``stream`` in :func:`scramble_keys`."""
    return np.uint64(2 * SOBOL_DIMENSIONS * stream + 1 + slot)


def key_hash(seed: Any, slot: Any) -> Any:
    """The 32-bit key (below 2^32, as uint64) of a query's 64-bit ``seed`` at a
    :func:`key_slot`: uint64 NumPy arrays, or uint64 scalars in numba (the same code)."""
    return _mix64(seed + slot * np.uint64(0xD1B54A32D192ED03)) >> np.uint64(32)
