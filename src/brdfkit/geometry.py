"""Frames, spherical coordinates, reflection and refraction, half/difference coordinates.

Conventions: the local shading frame has z the normal, x the tangent and y = z × x; spherical
coordinates are θ from +z and φ = atan2(y, x) from +x. Every function takes and returns arrays of
any supported backend with the direction on the last axis.

References
----------
.. [1] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation",
       Eurographics Workshop on Rendering, 1998.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §3.8, §9.3.
.. [3] T. Duff et al., "Building an orthonormal basis, revisited", JCGT 6(1), 2017.
"""

from __future__ import annotations

import math

from brdfkit._array import (
    Array,
    asarray,
    check_param,
    check_vectors,
    constant,
    cross,
    dot,
    namespace,
    norm,
    normalize,
    safe_sqrt,
)


# --------------------------------------------------------------------------- frames
def frame_from_normal(normal: Array, tangent: Array | None = None) -> tuple[Array, Array, Array]:
    """An orthonormal frame ``(s, t, n)`` around ``normal``: ``s`` the tangent, ``t = n × s``.

    With no ``tangent``, the branchless construction of Duff et al. (2017) is used; with one, it is
    made orthogonal to ``n`` by Gram–Schmidt (it must not be parallel to the normal).

    Returns
    -------
    s, t, n : each ``(..., 3)``.

    Examples
    --------
    >>> import numpy as np
    >>> frame = frame_from_normal([0.0, 1.0, 0.0])
    >>> to_local(np.array([0.0, 1.0, 0.0]), frame).tolist()  # the normal is the local +z
    [0.0, 0.0, 1.0]
    >>> to_world(np.array([0.0, 0.0, 1.0]), frame).tolist()
    [0.0, 1.0, 0.0]
    >>> s, t, n = frame_from_normal([0.0, 0.6, 0.8])
    >>> float(round(np.dot(s, t), 12)), float(round(np.dot(s, n), 12))
    (0.0, 0.0)
    """
    n = normalize(check_vectors("normal", normal))
    xp = namespace(n)
    if tangent is None:
        sign = xp.where(n[..., 2] >= 0, xp.ones_like(n[..., 2]), -xp.ones_like(n[..., 2]))
        a = -1 / (sign + n[..., 2])
        b = n[..., 0] * n[..., 1] * a
        s = xp.stack([1 + sign * n[..., 0] ** 2 * a, sign * b, -sign * n[..., 0]], axis=-1)
        t = xp.stack([b, sign + n[..., 1] ** 2 * a, -n[..., 1]], axis=-1)
        return s, t, n
    tangent = check_vectors("tangent", asarray(tangent, xp, like=n))
    s = tangent - dot(tangent, n, keepdims=True) * n
    length = norm(s)
    if not bool(xp.all(length > 1e-6)):
        raise ValueError("tangent must not be parallel to normal; got a parallel pair")
    s = s / length[..., None]
    return s, cross(n, s), n


def to_local(v: Array, frame: tuple[Array, Array, Array]) -> Array:
    """World vector(s) ``v`` expressed in the local frame ``(s, t, n)``."""
    s, t, n = frame
    xp = namespace(v, s)
    return xp.stack([dot(v, s), dot(v, t), dot(v, n)], axis=-1)


def to_world(v: Array, frame: tuple[Array, Array, Array]) -> Array:
    """Local vector(s) ``v`` in the frame ``(s, t, n)`` expressed in world coordinates."""
    s, t, n = frame
    return v[..., 0:1] * s + v[..., 1:2] * t + v[..., 2:3] * n


# --------------------------------------------------------------------------- spherical
def spherical_to_cartesian(theta: Array, phi: Array) -> Array:
    """Unit vector(s) at polar angle ``theta`` (from +z) and azimuth ``phi`` (from +x).

    Examples
    --------
    >>> import numpy as np
    >>> spherical_to_cartesian(np.pi / 4, np.pi / 2).round(4).tolist()
    [0.0, 0.7071, 0.7071]
    >>> spherical_to_cartesian(np.zeros(5), np.zeros(5)).shape
    (5, 3)
    """
    xp = namespace(theta, phi)
    theta = asarray(theta, xp, like=phi if hasattr(phi, "dtype") else None)
    phi = asarray(phi, xp, like=theta)
    theta, phi = xp.broadcast_arrays(theta, phi)
    sin_theta = xp.sin(theta)
    return xp.stack([sin_theta * xp.cos(phi), sin_theta * xp.sin(phi), xp.cos(theta)], axis=-1)


def cartesian_to_spherical(v: Array) -> tuple[Array, Array]:
    r"""``(theta, phi)`` of direction(s) ``v``: θ ∈ [0, π] from +z, φ ∈ (−π, π] from +x.

    :math:`\theta = \operatorname{atan2}(\sqrt{x^2 + y^2}, z)`, :math:`\phi =
    \operatorname{atan2}(y, x)`; ``v`` need not be normalised. Unlike :math:`\arccos z`, whose
    slope is infinite at the poles (a rounding error δ in z gives θ ≈ √(2δ)), the two-argument
    form is accurate to a few ulps everywhere, and its gradient stays finite at the poles.

    References
    ----------
    .. [1] M. Pharr et al., *Physically Based Rendering*, 4th ed., §3.8.3 (spherical polar
       coordinates).

    Examples
    --------
    >>> import numpy as np
    >>> theta, phi = cartesian_to_spherical([0.0, 2.0, 2.0])
    >>> float(np.degrees(theta)), float(np.degrees(phi))
    (45.0, 90.0)
    """
    v = check_vectors("v", v)
    xp = namespace(v)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    theta = xp.atan2(safe_sqrt(x * x + y * y), z)
    phi = xp.atan2(y, x)
    return theta, phi


# --------------------------------------------------------------------------- reflection
def reflect(w: Array, normal: Array | None = None) -> Array:
    """Mirror direction of ``w`` about ``normal`` (default +z): 2(w·n)n − w.

    Both ``w`` and the result point away from the surface.

    Examples
    --------
    >>> reflect([0.6, 0.48, 0.64]).tolist()
    [-0.6, -0.48, 0.64]
    >>> reflect([0.6, 0.48, 0.64], normal=[1.0, 0.0, 0.0]).tolist()
    [0.6, -0.48, -0.64]
    """
    w = check_vectors("w", w)
    xp = namespace(w)
    if normal is None:
        return xp.stack([-w[..., 0], -w[..., 1], w[..., 2]], axis=-1)
    n = asarray(check_vectors("normal", normal), xp, like=w)
    return 2 * dot(w, n, keepdims=True) * n - w


def refract(w: Array, eta: Array | float, normal: Array | None = None) -> tuple[Array, Array]:
    """Refracted direction of ``w`` through an interface of relative index ``eta``, by Snell.

    ``w`` points away from the surface on the incident side; ``eta = η_t / η_i`` is the index on
    the far side of ``normal`` (default +z) over the index on ``w``'s side when ``w·n > 0``;
    when ``w`` lies below (``w·n < 0``) the roles swap and ``1/eta`` is used, as for light leaving
    a dielectric. The result points away from the surface on the other side. Snell's law
    η_i sinθ_i = η_t sinθ_t and conservation of tangential momentum hold:
    ``η_t·(w_t − (w_t·n)n) = −η_i·(w − (w·n)n)``.

    Returns
    -------
    w_t : (..., 3) refracted direction (zero where total internal reflection occurs).
    valid : (...,) bool, False under total internal reflection.

    Examples
    --------
    Into glass (η = 1.5) at sin θ_i = 0.6, so sin θ_t = 0.4; out of it, beyond the critical angle:

    >>> import numpy as np
    >>> w_t, valid = refract([0.48, 0.36, 0.8], 1.5)
    >>> w_t.round(4).tolist(), bool(valid)
    ([-0.32, -0.24, -0.9165], True)
    >>> bool(refract([0.72, 0.54, -0.4359], 1.5)[1])
    False
    """
    w = check_vectors("w", w)
    xp = namespace(w, eta)
    eta = asarray(eta, xp, like=w)
    check_param("eta", eta, 0.0, lo_open=True)
    n = (
        xp.asarray([0.0, 0.0, 1.0], dtype=w.dtype)
        if normal is None
        else normalize(asarray(check_vectors("normal", normal), xp, like=w))
    )
    cos_theta_i = dot(w, n)
    entering = cos_theta_i > 0
    eta_rel = xp.where(entering, eta, 1 / eta)  # η_t / η_i for this side
    n_side = xp.where(entering[..., None], n, -n)
    cos_i = xp.abs(cos_theta_i)
    sin2_theta_t = (1 - cos_i * cos_i) / (eta_rel * eta_rel)
    valid = sin2_theta_t < 1
    cos_theta_t = safe_sqrt(1 - sin2_theta_t)
    w_t = -w / eta_rel[..., None] + (cos_i / eta_rel - cos_theta_t)[..., None] * n_side
    w_t = xp.where(valid[..., None], w_t, xp.zeros_like(w_t))
    return w_t, valid


def critical_angle(eta: Array | float) -> Array:
    """Critical angle θ_c = arcsin(1/η) (radians) for light leaving a medium of relative index η.

    Examples
    --------
    >>> import numpy as np
    >>> float(np.degrees(critical_angle(1.5)).round(4))
    41.8103
    """
    xp = namespace(eta)
    eta = asarray(eta, xp)
    check_param("eta", eta, 1.0, hint="for a critical angle to exist")
    return xp.asin(1 / eta)


def half_vector(wi: Array, wo: Array) -> Array:
    """The normalised half vector h = ``(wi + wo)/|wi + wo|`` of a reflection pair.

    Examples
    --------
    >>> import numpy as np
    >>> half_vector(np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.6, 0.8])).round(4).tolist()
    [0.3313, 0.3313, 0.8835]
    """
    return normalize(wi + wo)


# --------------------------------------------------------------------------- half/difference
def _rotate_z(v: Array, angle: Array) -> Array:
    xp = namespace(v, angle)
    c, s = xp.cos(angle), xp.sin(angle)
    return xp.stack(
        [c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1], v[..., 2]], axis=-1
    )


def _rotate_y(v: Array, angle: Array) -> Array:
    xp = namespace(v, angle)
    c, s = xp.cos(angle), xp.sin(angle)
    return xp.stack(
        [c * v[..., 0] + s * v[..., 2], v[..., 1], -s * v[..., 0] + c * v[..., 2]], axis=-1
    )


def to_half_diff(wi: Array, wo: Array) -> tuple[Array, Array, Array, Array]:
    """Rusinkiewicz (1998) half/difference angles ``(theta_h, phi_h, theta_d, phi_d)`` of a pair.

    h = normalize(wi + wo) has spherical angles (θh, φh); the difference vector is ``wi`` rotated
    by −φh about z, then by −θh about y, and has spherical angles (θd, φd). (θh, θd) ∈ [0, π/2]²
    for pairs in the upper hemisphere; φh, φd ∈ (−π, π].

    Examples
    --------
    A mirror pair has θd = θi and its half vector at the normal; :func:`from_half_diff` inverts:

    >>> import numpy as np
    >>> angles = to_half_diff([0.6, 0.0, 0.8], [-0.6, 0.0, 0.8])
    >>> [float(np.degrees(a).round(4)) for a in angles]
    [0.0, 0.0, 36.8699, 0.0]
    >>> wi, wo = from_half_diff(*to_half_diff([0.6, 0.0, 0.8], [0.0, 0.6, 0.8]))
    >>> wi.round(4).tolist(), wo.round(4).tolist()
    ([0.6, 0.0, 0.8], [0.0, 0.6, 0.8])
    """
    wi = normalize(check_vectors("wi", wi))
    wo = normalize(asarray(check_vectors("wo", wo), like=wi))
    h = half_vector(wi, wo)
    theta_h, phi_h = cartesian_to_spherical(h)
    d = _rotate_y(_rotate_z(wi, -phi_h), -theta_h)
    theta_d, phi_d = cartesian_to_spherical(d)
    return theta_h, phi_h, theta_d, phi_d


def from_half_diff(
    theta_h: Array, phi_h: Array, theta_d: Array, phi_d: Array
) -> tuple[Array, Array]:
    """Inverse of :func:`to_half_diff`: the pair ``(wi, wo)`` from half/difference angles."""
    xp = namespace(theta_h, phi_h, theta_d, phi_d)
    h = spherical_to_cartesian(theta_h, phi_h)
    d = spherical_to_cartesian(theta_d, phi_d)
    wi = _rotate_z(_rotate_y(d, asarray(theta_h, xp, like=h)), asarray(phi_h, xp, like=h))
    wo = 2 * dot(wi, h, keepdims=True) * h - wi
    return wi, wo


def to_isotropic(wi: Array, wo: Array) -> tuple[Array, Array, Array]:
    """Isotropic reduction ``(theta_i, theta_o, delta_phi)`` with Δφ = φo − φi wrapped to [0, π].

    An isotropic BRDF depends only on these three numbers (and, being reciprocal, on ``|Δφ|``).

    Examples
    --------
    >>> import numpy as np
    >>> theta_i, theta_o, delta_phi = to_isotropic([0.6, 0.0, 0.8], [0.0, 0.6, 0.8])
    >>> float(theta_i.round(4)), float(theta_o.round(4)), float(np.degrees(delta_phi))
    (0.6435, 0.6435, 90.0)
    """
    theta_i, phi_i = cartesian_to_spherical(wi)
    theta_o, phi_o = cartesian_to_spherical(wo)
    xp = namespace(phi_i, phi_o)
    two_pi = constant(2 * math.pi, phi_i)
    delta = xp.remainder(phi_o - phi_i, two_pi)
    delta_phi = xp.where(delta > math.pi, two_pi - delta, delta)
    return theta_i, theta_o, delta_phi


__all__ = [
    "cartesian_to_spherical",
    "critical_angle",
    "frame_from_normal",
    "from_half_diff",
    "half_vector",
    "reflect",
    "refract",
    "spherical_to_cartesian",
    "to_half_diff",
    "to_isotropic",
    "to_local",
    "to_world",
]
