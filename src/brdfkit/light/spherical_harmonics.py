r"""Real spherical harmonics, lat-long projection, Ramamoorthi–Hanrahan irradiance, rotation.

Conventions (shared with the environment-map light and every module that reads this one)
-----------------------------------------------------------------------------------------

**Real spherical harmonics.** For degree ``l`` and order ``-l ≤ m ≤ l``, with
:math:`K_l^m = \sqrt{\tfrac{2l+1}{4\pi}\tfrac{(l-m)!}{(l+m)!}}` and the associated Legendre
functions :math:`P_l^m` *without* the Condon–Shortley phase :math:`(-1)^m`,

.. math::

    Y_{lm} = \begin{cases}
      \sqrt2\,K_l^m P_l^m(\cos\theta)\cos(m\phi) & m > 0 \\
      K_l^0 P_l^0(\cos\theta) & m = 0 \\
      \sqrt2\,K_l^{|m|} P_l^{|m|}(\cos\theta)\sin(|m|\phi) & m < 0.
    \end{cases}

This is the convention of Ramamoorthi & Hanrahan (2001) and of Wikipedia's table of real
spherical harmonics: :math:`Y_{1,-1} = \sqrt{3/4\pi}\,y`, :math:`Y_{10} = \sqrt{3/4\pi}\,z`,
:math:`Y_{11} = \sqrt{3/4\pi}\,x`. In terms of the complex harmonics with the Condon–Shortley
phase (``scipy.special.sph_harm_y``), :math:`Y_{lm} = \sqrt2(-1)^m\,\mathrm{Re}\,Y_l^m` for
``m > 0`` and :math:`\sqrt2(-1)^m\,\mathrm{Im}\,Y_l^{|m|}` for ``m < 0``. Sloan's "Stupid SH
tricks" keeps the Condon–Shortley phase, so its coefficients differ from ours by :math:`(-1)^m`.
The basis is orthonormal on the unit sphere. Coefficients are stored flat at index
``k = l(l+1) + m`` (:func:`sh_index`), so an expansion up to degree ``order`` has
``(order + 1)**2`` of them: ``L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22, ...``.

**Lat-long (equirectangular) maps** use pbrt-v3's convention: world frame with +z up,
:math:`\theta = \arccos z` from +z, :math:`\phi = \operatorname{atan2}(y, x)` wrapped to
:math:`[0, 2\pi)`, and ``u = φ / 2π``, ``v = θ / π``. Row ``i`` of an ``H × W`` map spans
:math:`\theta \in [\pi i/H, \pi(i+1)/H]` (row 0 is the top, around +z), column ``j`` spans
:math:`\phi \in [2\pi j/W, 2\pi(j+1)/W]` (column 0 starts at +x and φ grows towards +y).
Pixel-centre direction: :math:`(\sin\theta\cos\phi, \sin\theta\sin\phi, \cos\theta)` at
:math:`\theta = \pi(i+\tfrac12)/H`, :math:`\phi = 2\pi(j+\tfrac12)/W`.

References
----------
.. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance environment
   maps", SIGGRAPH 2001, pp. 497–500.
.. [2] P.-P. Sloan, "Stupid spherical harmonics (SH) tricks", GDC 2008.
.. [3] J. Ivanic and K. Ruedenberg, "Rotation matrices for real spherical harmonics. Direct
   determination by recursion", J. Phys. Chem. 100(15), 1996, pp. 6342–6347; additions and
   corrections, J. Phys. Chem. A 102(45), 1998, pp. 9099–9100.
.. [4] M. Pharr, W. Jakob and G. Humphreys, *Physically Based Rendering*, 3rd ed., §14.2.4
   (infinite area lights, lat-long parameterisation).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from array_api_compat import device

from brdfkit._array import (
    Array,
    asarray,
    check_finite,
    check_vectors,
    float_dtype,
    namespace,
    normalize,
    to_numpy,
)
from brdfkit.geometry import spherical_to_cartesian

__all__ = [
    "irradiance_brute_force",
    "irradiance_map",
    "irradiance_sh",
    "lambertian_convolve",
    "lambertian_kernel",
    "latlong_directions",
    "latlong_solid_angles",
    "project_latlong",
    "reconstruct",
    "rotate_sh",
    "sh_basis",
    "sh_index",
    "sh_rotation_matrix",
]

# Ramamoorthi & Hanrahan 2001, eq. 12: E(n) as a quadratic form in the normal. The closed forms
# below agree with the published six-digit constants 0.429043, 0.511664, 0.743125, 0.886227,
# 0.247708 to 1.5e-6 relative (some published digits were rounded from the rounded Y_lm
# constants of their eq. 3, e.g. c3 = 3·(π/4)·0.315392) and make the quadratic form identical
# to the convolution with Â_l = π, 2π/3, π/4 (see :func:`lambertian_kernel`).
RH_C1 = math.sqrt(15.0 * math.pi) / 16.0
RH_C2 = math.sqrt(math.pi / 3.0) / 2.0
RH_C3 = 3.0 * math.sqrt(5.0 * math.pi) / 16.0
RH_C4 = math.sqrt(math.pi) / 2.0
RH_C5 = math.sqrt(5.0 * math.pi) / 16.0


def _check_order(order: int) -> int:
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 0:
        raise ValueError(
            f"order must be a non-negative integer (the maximum degree l); got {order!r}"
        )
    return int(order)


def _check_size(name: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{name} must be a positive integer number of pixels; got {value!r}")
    return int(value)


def sh_index(l: int, m: int) -> int:
    """Flat index ``k = l(l+1) + m`` of the real harmonic ``Y_lm`` (``|m| ≤ l``).

    References
    ----------
    .. [1] P.-P. Sloan, "Stupid spherical harmonics (SH) tricks", GDC 2008, §2.

    Examples
    --------
    >>> sh_index(0, 0), sh_index(1, -1), sh_index(2, 2)
    (0, 1, 8)
    """
    if l < 0 or abs(m) > l:
        raise ValueError(f"(l, m) must satisfy l >= 0 and |m| <= l; got l={l}, m={m}")
    return l * (l + 1) + m


def _order_of(coeffs: Array) -> int:
    n = coeffs.shape[0] if coeffs.ndim else 0
    order = math.isqrt(n) - 1
    if coeffs.ndim != 2 or n == 0 or (order + 1) ** 2 != n:
        raise ValueError(
            "coeffs must have shape (n_coeffs, C) with n_coeffs = (order + 1)**2 "
            f"(1, 4, 9, 16, ...); got shape {tuple(coeffs.shape)}"
        )
    return order


def _legendre_scaled(z: Array, order: int) -> dict[tuple[int, int], Array]:
    r"""Π_l^m(z) such that Y_{l,±m} = Π_l^m(z) · Re/Im((x + i y)^m) on the unit sphere.

    Π_l^m = c_m K_l^m P_l^m(z) / sinᵐθ with c_0 = 1 and c_m = √2, a polynomial in ``z``,
    computed by the standard three-term recurrence of the fully normalised functions
    (stable for any degree: no factorials and no division by sin θ)::

        Q_0^0 = 1/√(4π),   Q_m^m = √((2m+1)/(2m)) Q_{m-1}^{m-1},   Q_{m+1}^m = √(2m+3) z Q_m^m,
        Q_l^m = a_lm (z Q_{l-1}^m − b_lm Q_{l-2}^m),
        a_lm = √((4l²−1)/(l²−m²)),  b_lm = √(((l−1)²−m²)/(4(l−1)²−1)).
    """
    one = z * 0 + 1
    diagonal = 1.0 / math.sqrt(4.0 * math.pi)
    q: dict[tuple[int, int], Array] = {}
    for m in range(order + 1):
        if m > 0:
            diagonal *= math.sqrt((2 * m + 1) / (2 * m))
        q[m, m] = diagonal * one
        if m + 1 <= order:
            q[m + 1, m] = math.sqrt(2 * m + 3) * z * q[m, m]
        for l in range(m + 2, order + 1):
            a = math.sqrt((4 * l * l - 1) / (l * l - m * m))
            b = math.sqrt(((l - 1) ** 2 - m * m) / (4 * (l - 1) ** 2 - 1))
            q[l, m] = a * (z * q[l - 1, m] - b * q[l - 2, m])
    return {(l, m): (math.sqrt(2.0) * v if m else v) for (l, m), v in q.items()}


def _azimuthal(x: Array, y: Array, order: int) -> tuple[list[Array], list[Array]]:
    """``Re((x + i y)^m)`` and ``Im((x + i y)^m)`` for m = 0..order (sinᵐθ cos mφ, sinᵐθ sin mφ)."""
    cos_terms, sin_terms = [x * 0 + 1], [x * 0]
    for _ in range(order):
        c, s = cos_terms[-1], sin_terms[-1]
        cos_terms.append(x * c - y * s)
        sin_terms.append(x * s + y * c)
    return cos_terms, sin_terms


def sh_basis(directions: Array, order: int) -> Array:
    r"""Real spherical harmonics :math:`Y_{lm}` of all degrees ``l ≤ order`` at ``directions``.

    The harmonics follow the module's convention (no Condon–Shortley phase, orthonormal):
    :math:`Y_{lm} = \sqrt2 K_l^m P_l^m(\cos\theta)\cos m\phi` for ``m > 0``,
    :math:`K_l^0 P_l^0(\cos\theta)` for ``m = 0`` and
    :math:`\sqrt2 K_l^{|m|} P_l^{|m|}(\cos\theta)\sin |m|\phi` for ``m < 0``. They are evaluated
    as polynomials in the Cartesian components (Legendre recurrence in ``z`` times
    ``Re/Im (x + i y)^m``), so any degree is stable and gradients are finite at the poles.

    Parameters
    ----------
    directions : array (..., 3)
        Directions; normalised internally.
    order : int
        Maximum degree ``l``.

    Returns
    -------
    array (..., (order + 1)**2)
        ``Y_lm`` at index ``l(l+1) + m``, in the dtype of ``directions``.

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, eq. 3 and appendix.
    .. [2] P.-P. Sloan, "Stupid spherical harmonics (SH) tricks", GDC 2008, §2 and appendix.

    Examples
    --------
    At the zenith only the m = 0 harmonics are non-zero: :math:`Y_{00} = 1/(2\sqrt\pi)`,
    :math:`Y_{10} = \sqrt{3/4\pi}`:

    >>> import numpy as np
    >>> sh_basis(np.array([0.0, 0.0, 1.0]), 1).round(4).tolist()
    [0.2821, 0.0, 0.4886, 0.0]
    """
    order = _check_order(order)
    directions = normalize(check_vectors("directions", directions))
    xp = namespace(directions)
    x, y, z = directions[..., 0], directions[..., 1], directions[..., 2]
    legendre = _legendre_scaled(z, order)
    cos_terms, sin_terms = _azimuthal(x, y, order)
    columns = []
    for l in range(order + 1):
        for m in range(-l, l + 1):
            azimuthal = sin_terms[-m] if m < 0 else cos_terms[m]
            columns.append(legendre[l, abs(m)] * azimuthal)
    return xp.stack(columns, axis=-1)


def _latlong_angles(height: int, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel-centre θ (H,), φ (W,) and the row's exact solid angle per pixel (H,), in float64."""
    height, width = _check_size("height", height), _check_size("width", width)
    theta_edges = np.linspace(0.0, np.pi, height + 1)
    theta = (np.arange(height) + 0.5) * (np.pi / height)
    phi = (np.arange(width) + 0.5) * (2.0 * np.pi / width)
    solid_angle = (np.cos(theta_edges[:-1]) - np.cos(theta_edges[1:])) * (2.0 * np.pi / width)
    return theta, phi, solid_angle


def latlong_directions(height: int, width: int, *, like: Array | None = None) -> Array:
    r"""Pixel-centre directions of an ``height × width`` lat-long map (pbrt-v3 convention).

    :math:`\omega_{ij} = (\sin\theta_i\cos\phi_j, \sin\theta_i\sin\phi_j, \cos\theta_i)` with
    :math:`\theta_i = \pi(i+\tfrac12)/H` (row 0 at the top, next to +z) and
    :math:`\phi_j = 2\pi(j+\tfrac12)/W` (column 0 starts at +x, φ grows towards +y).

    Parameters
    ----------
    height, width : int
        Map size in pixels.
    like : array, optional
        Array whose namespace, dtype and device the result takes (NumPy float64 by default).

    Returns
    -------
    array (height, width, 3)

    References
    ----------
    .. [1] M. Pharr, W. Jakob and G. Humphreys, *Physically Based Rendering*, 3rd ed., §14.2.4.

    Examples
    --------
    >>> directions = latlong_directions(2, 4)
    >>> directions.shape, directions[0, 0].round(4).tolist()  # row 0 around +z, column 0 at +x
    ((2, 4, 3), [0.5, 0.5, 0.7071])
    """
    theta, phi, _ = _latlong_angles(height, width)
    directions = spherical_to_cartesian(theta[:, None], phi[None, :])
    return directions if like is None else asarray(directions, like=like, dtype=like.dtype)


def latlong_solid_angles(height: int, width: int, *, like: Array | None = None) -> Array:
    r"""Exact solid angle of every pixel of an ``height × width`` lat-long map; they sum to 4π.

    :math:`\Delta\Omega_{ij} = (\cos\theta_i^- - \cos\theta_i^+)\,\Delta\phi` with
    :math:`\theta_i^\pm` the row's edges and :math:`\Delta\phi = 2\pi/W`
    (the integral of :math:`\sin\theta\,d\theta\,d\phi` over the pixel).

    Parameters
    ----------
    height, width : int
        Map size in pixels.
    like : array, optional
        Array whose namespace, dtype and device the result takes (NumPy float64 by default).

    Returns
    -------
    array (height, width)
        Steradians.

    References
    ----------
    .. [1] M. Pharr, W. Jakob and G. Humphreys, *Physically Based Rendering*, 3rd ed., §5.5.1.

    Examples
    --------
    >>> import numpy as np
    >>> float((latlong_solid_angles(8, 16).sum() / np.pi).round(12))
    4.0
    """
    _, _, solid_angle = _latlong_angles(height, width)
    pixels = np.broadcast_to(solid_angle[:, None], (solid_angle.size, int(width)))
    return pixels.copy() if like is None else asarray(pixels, like=like, dtype=like.dtype)


def _check_latlong(name: str, image: Array) -> Array:
    xp = namespace(image)
    image = asarray(image, xp)
    if image.ndim != 3:
        raise ValueError(
            f"{name} must be a lat-long image of shape (height, width, channels); "
            f"got shape {tuple(image.shape)}"
        )
    return check_finite(name, image)


def project_latlong(image: Array, order: int) -> Array:
    r"""SH coefficients of a lat-long map, :math:`L_{lm} = \int L(\omega) Y_{lm}(\omega)\,d\omega`.

    The integral is the sum over pixels of the pixel value times :math:`Y_{lm}` at the pixel
    centre times the pixel's exact solid angle (:func:`latlong_solid_angles`). It is computed
    separably (a Fourier sum over each row, then the Legendre sum over rows), which equals the
    direct sum over pixels but costs O(H·W·order) instead of O(H·W·order²).

    Parameters
    ----------
    image : array (H, W, C)
        Lat-long map in the module's convention (radiance, or any function on the sphere).
    order : int
        Maximum degree ``l``.

    Returns
    -------
    array ((order + 1)**2, C)
        ``L_lm`` at index ``l(l+1) + m``, in the dtype of ``image``.

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, eq. 10.

    Examples
    --------
    A uniform sky of radiance 1 has only :math:`L_{00} = \int Y_{00} = 2\sqrt\pi` (to the
    map's quadrature error):

    >>> import numpy as np
    >>> coeffs = project_latlong(np.ones((16, 32, 1)), 2)
    >>> coeffs.shape, float((coeffs[0, 0] / (2 * np.sqrt(np.pi))).round(12))
    ((9, 1), 1.0)
    >>> float(np.abs(coeffs[1:]).max().round(2))
    0.01
    """
    order = _check_order(order)
    image = _check_latlong("image", image)
    xp = namespace(image)
    height, width = image.shape[0], image.shape[1]
    theta, phi, solid_angle = _latlong_angles(height, width)
    m = np.arange(order + 1)[:, None]
    # Per row: Σ_j L_ij cos(mφ_j) and Σ_j L_ij sin(mφ_j), shape (H, C, order + 1).
    cos_sums = xp.tensordot(
        image, asarray(np.cos(m * phi), like=image, dtype=image.dtype), axes=([1], [1])
    )
    sin_sums = xp.tensordot(
        image, asarray(np.sin(m * phi), like=image, dtype=image.dtype), axes=([1], [1])
    )
    # Per row: Π_l^m(cos θ) sinᵐθ ΔΩ, so that Π_l^m sinᵐθ cos(mφ) = Y_lm.
    legendre = _legendre_scaled(np.cos(theta), order)
    coeffs = []
    for l in range(order + 1):
        for mm in range(-l, l + 1):
            weight = legendre[l, abs(mm)] * np.sin(theta) ** abs(mm) * solid_angle
            sums = sin_sums[..., -mm] if mm < 0 else cos_sums[..., mm]
            coeffs.append(
                xp.tensordot(asarray(weight, like=image, dtype=image.dtype), sums, axes=([0], [0]))
            )
    return xp.stack(coeffs, axis=0)


def reconstruct(coeffs: Array, directions: Array) -> Array:
    r"""The SH expansion :math:`f(\omega) = \sum_{lm} c_{lm} Y_{lm}(\omega)` at ``directions``.

    Parameters
    ----------
    coeffs : array ((order + 1)**2, C)
        Coefficients at index ``l(l+1) + m``.
    directions : array (..., 3)
        Directions; normalised internally.

    Returns
    -------
    array (..., C)

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, eq. 3.

    Examples
    --------
    >>> import numpy as np
    >>> coeffs = np.zeros((4, 1))
    >>> coeffs[sh_index(1, 0)] = np.sqrt(4 * np.pi / 3)  # the function z
    >>> reconstruct(coeffs, np.array([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8]])).round(12).tolist()
    [[1.0], [-0.8]]
    """
    xp = namespace(coeffs, directions)
    coeffs = asarray(coeffs, xp)
    order = _order_of(coeffs)
    basis = sh_basis(asarray(directions, xp, like=coeffs), order)
    return xp.matmul(basis, asarray(coeffs, xp, like=basis))


def lambertian_kernel(order: int) -> np.ndarray:
    r"""Ramamoorthi–Hanrahan coefficients :math:`\hat A_l` of the clamped cosine, l = 0..order.

    Irradiance is the convolution :math:`E_{lm} = \hat A_l L_{lm}` with
    :math:`\hat A_0 = \pi`, :math:`\hat A_1 = 2\pi/3`, :math:`\hat A_l = 0` for odd ``l > 1`` and,
    for even ``l``,

    .. math:: \hat A_l = 2\pi \frac{(-1)^{l/2-1}}{(l+2)(l-1)} \frac{l!}{2^l ((l/2)!)^2}

    (π/4 for l = 2). :math:`\hat A_l = \sqrt{4\pi/(2l+1)}\,A_l` where :math:`A_l` are the SH
    coefficients of :math:`\max(\cos\theta, 0)`.

    Returns
    -------
    numpy.ndarray (order + 1,)
        Float64.

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, eqs. 7–9.

    Examples
    --------
    π, 2π/3, π/4, then zero for odd degrees:

    >>> import numpy as np
    >>> (lambertian_kernel(4) / np.pi).round(4).tolist()
    [1.0, 0.6667, 0.25, 0.0, -0.0417]
    """
    order = _check_order(order)
    kernel = np.zeros(order + 1)
    kernel[0] = math.pi
    if order >= 1:
        kernel[1] = 2.0 * math.pi / 3.0
    for l in range(2, order + 1, 2):
        sign = -1.0 if (l // 2 - 1) % 2 else 1.0
        kernel[l] = 2.0 * math.pi * sign / ((l + 2) * (l - 1)) * math.comb(l, l // 2) / 2.0**l
    return kernel


def lambertian_convolve(coeffs: Array) -> Array:
    r"""Irradiance SH coefficients :math:`E_{lm} = \hat A_l L_{lm}` from radiance coefficients.

    ``reconstruct(lambertian_convolve(L), n)`` is the irradiance
    :math:`E(n) = \int L(\omega)\max(n\cdot\omega, 0)\,d\omega` of the band-limited radiance,
    for any order.

    Parameters
    ----------
    coeffs : array ((order + 1)**2, C)
        Radiance coefficients ``L_lm``.

    Returns
    -------
    array ((order + 1)**2, C)

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, eqs. 7 and 11.

    Examples
    --------
    >>> import numpy as np
    >>> radiance = np.zeros((4, 1))
    >>> radiance[0] = 2 * np.sqrt(np.pi)  # a uniform sky of radiance 1
    >>> (lambertian_convolve(radiance)[0] / radiance[0] / np.pi).round(12).tolist()
    [1.0]
    """
    xp = namespace(coeffs)
    coeffs = asarray(coeffs, xp)
    order = _order_of(coeffs)
    kernel = lambertian_kernel(order)
    per_coeff = np.repeat(kernel, 2 * np.arange(order + 1) + 1)[:, None]
    return coeffs * asarray(per_coeff, like=coeffs, dtype=coeffs.dtype)


def irradiance_sh(coeffs9: Array, normals: Array) -> Array:
    r"""Irradiance from 9 radiance SH coefficients: Ramamoorthi & Hanrahan's quadratic form.

    .. math::

        E(n) = c_1 L_{22}(x^2 - y^2) + c_3 L_{20} z^2 + c_4 L_{00} - c_5 L_{20}
             + 2c_1(L_{2,-2}xy + L_{21}xz + L_{2,-1}yz) + 2c_2(L_{11}x + L_{1,-1}y + L_{10}z)

    with :math:`c_1 = \sqrt{15\pi}/16`, :math:`c_2 = \sqrt{\pi/3}/2`, :math:`c_3 = 3\sqrt{5\pi}/16`,
    :math:`c_4 = \sqrt\pi/2`, :math:`c_5 = \sqrt{5\pi}/16` — the published 0.429043, 0.511664,
    0.743125, 0.886227, 0.247708 before rounding — which makes it exactly the convolution with
    :math:`\hat A_l = \pi, 2\pi/3, \pi/4` (:func:`lambertian_convolve`).

    Parameters
    ----------
    coeffs9 : array (9, C)
        Radiance coefficients ``L_lm`` for ``l ≤ 2`` (e.g. from :func:`project_latlong`).
    normals : array (..., 3)
        Surface normals; normalised internally.

    Returns
    -------
    array (..., C)
        Irradiance in W·m⁻² when ``coeffs9`` are radiance coefficients in W·m⁻²·sr⁻¹.

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, eqs. 12–13.

    Examples
    --------
    Under a sky of radiance 1 over the upper hemisphere and darkness below, a surface facing
    up receives about π, one facing sideways π/2 and one facing down almost nothing (nine
    coefficients ring a little, below zero here):

    >>> import numpy as np
    >>> image = np.zeros((16, 32, 1))
    >>> image[:8] = 1.0
    >>> normals = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    >>> E = irradiance_sh(project_latlong(image, 2), normals)
    >>> (E[:, 0] / np.pi).round(3).tolist()
    [1.003, 0.499, -0.001]
    >>> (irradiance_brute_force(image, normals)[:, 0] / np.pi).round(3).tolist()
    [1.005, 0.5, 0.0]
    """
    xp = namespace(coeffs9, normals)
    coeffs9 = asarray(coeffs9, xp)
    if _order_of(coeffs9) != 2:
        raise ValueError(f"coeffs9 must have shape (9, C); got shape {tuple(coeffs9.shape)}")
    normals = normalize(check_vectors("normals", asarray(normals, xp, like=coeffs9)))
    coeffs9 = asarray(coeffs9, xp, like=normals)
    x, y, z = (normals[..., i : i + 1] for i in range(3))
    L00, L1m1, L10, L11, L2m2, L2m1, L20, L21, L22 = (coeffs9[k] for k in range(9))
    return (
        RH_C1 * L22 * (x * x - y * y)
        + RH_C3 * L20 * z * z
        + RH_C4 * L00
        - RH_C5 * L20
        + 2.0 * RH_C1 * (L2m2 * x * y + L21 * x * z + L2m1 * y * z)
        + 2.0 * RH_C2 * (L11 * x + L1m1 * y + L10 * z)
    )


def irradiance_brute_force(
    latlong_image: np.ndarray, normals: np.ndarray, chunk: int = 16384
) -> np.ndarray:
    r"""Irradiance by summing the map's pixels, the reference that :func:`irradiance_sh`
    approximates: :math:`E(n) = \sum_{pixels} L\,\max(n\cdot\omega, 0)\,\Delta\Omega`.

    Parameters
    ----------
    latlong_image : array (H, W, C)
        Radiance on the lat-long grid of :func:`latlong_directions`.
    normals : array (N, 3)
        Unit normals.
    chunk : int
        Pixels per block of the sum (an N × ``chunk`` block of cosines at a time, so a
        full-resolution map needs no N × H·W matrix).

    Returns
    -------
    array (N, C)

    Examples
    --------
    A uniform map of radiance 1 gives π to the quadrature's error (white-out):

    >>> import numpy as np
    >>> E = irradiance_brute_force(np.ones((32, 64, 1)), np.array([[0.0, 0.0, 1.0]]))
    >>> float((E[0, 0] / np.pi).round(2))
    1.0
    """
    height, width, channels = latlong_image.shape
    directions = latlong_directions(height, width).reshape(-1, 3)
    solid_angles = latlong_solid_angles(height, width).reshape(-1, 1)
    weighted = np.asarray(latlong_image).reshape(-1, channels) * solid_angles
    total = np.zeros((len(normals), channels))
    for start in range(0, len(directions), chunk):
        cosine = np.maximum(normals @ directions[start : start + chunk].T, 0.0)
        total += cosine @ weighted[start : start + chunk]
    return total


def irradiance_map(
    latlong_image: Array, height: int | None = None, width: int | None = None
) -> Array:
    r"""The irradiance environment map of a lat-long radiance map (Ramamoorthi & Hanrahan).

    Projects ``latlong_image`` onto the 9 harmonics ``l ≤ 2`` (:func:`project_latlong`) and
    evaluates :math:`E(n)` (:func:`irradiance_sh`) at the pixel-centre directions of a
    ``height × width`` lat-long map. Pixel values are irradiance, W·m⁻²; a Lambertian surface of
    albedo ρ and normal n reflects radiance :math:`\rho E(n)/\pi`.

    Parameters
    ----------
    latlong_image : array (H, W, C)
        Radiance map in the module's lat-long convention.
    height, width : int, optional
        Size of the output map; by default that of ``latlong_image``.

    Returns
    -------
    array (height, width, C)

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance
       environment maps", SIGGRAPH 2001, §3–4.

    Examples
    --------
    >>> import numpy as np
    >>> irradiance_map(np.ones((16, 32, 3)), height=4, width=8).shape
    (4, 8, 3)
    """
    latlong_image = _check_latlong("latlong_image", latlong_image)
    height = latlong_image.shape[0] if height is None else _check_size("height", height)
    width = latlong_image.shape[1] if width is None else _check_size("width", width)
    coeffs9 = project_latlong(latlong_image, 2)
    return irradiance_sh(coeffs9, latlong_directions(height, width, like=coeffs9))


def _check_rotation(rotation: Array) -> Array:
    xp = namespace(rotation)
    rotation = asarray(rotation, xp)
    if tuple(rotation.shape) != (3, 3):
        raise ValueError(f"rotation must be a 3×3 matrix; got shape {tuple(rotation.shape)}")
    check_finite("rotation", rotation)
    values = to_numpy(rotation)
    matrix = values.astype(np.float64)
    tolerance = math.sqrt(np.finfo(values.dtype).eps)
    error = np.abs(matrix.T @ matrix - np.eye(3)).max()
    if error > tolerance or np.linalg.det(matrix) < 0:
        raise ValueError(
            "rotation must be a proper rotation matrix (RᵀR = I, det R = +1); got one with "
            f"max |RᵀR − I| = {error:.3g} and det R = {np.linalg.det(matrix):.6g}"
        )
    return rotation


def _band_rotations(rotation: Array, order: int) -> list[Array]:
    """Per-band rotation matrices D^l ((2l+1)×(2l+1)) by the Ivanic–Ruedenberg recurrence."""
    xp = namespace(rotation)
    # Band 1 harmonics are proportional to (y, z, x) for m = -1, 0, 1.
    axis = {-1: 1, 0: 2, 1: 0}
    r = {(i, j): rotation[axis[i], axis[j]] for i in (-1, 0, 1) for j in (-1, 0, 1)}
    bands: list[dict[tuple[int, int], Array]] = [{(0, 0): rotation[0, 0] * 0 + 1}, r]
    for l in range(2, order + 1):
        prev = bands[-1]

        def p(i: int, a: int, b: int, l: int = l, prev: dict = prev) -> Array:
            if b == l:
                return r[i, 1] * prev[a, l - 1] - r[i, -1] * prev[a, 1 - l]
            if b == -l:
                return r[i, 1] * prev[a, 1 - l] + r[i, -1] * prev[a, l - 1]
            return r[i, 0] * prev[a, b]

        band = {}
        for m in range(-l, l + 1):
            d = 1 if m == 0 else 0
            for n in range(-l, l + 1):
                denom = 2 * l * (2 * l - 1) if abs(n) == l else (l + n) * (l - n)
                u = math.sqrt((l + m) * (l - m) / denom)
                v = 0.5 * math.sqrt((1 + d) * (l + abs(m) - 1) * (l + abs(m)) / denom) * (1 - 2 * d)
                w = -0.5 * math.sqrt((l - abs(m) - 1) * (l - abs(m)) / denom) * (1 - d)
                total = v * _ir_v(p, m, n)
                if u:
                    total = total + u * p(0, m, n)
                if w:
                    total = total + w * _ir_w(p, m, n)
                band[m, n] = total
        bands.append(band)
    return [
        xp.stack([xp.stack([band[m, n] for n in range(-l, l + 1)]) for m in range(-l, l + 1)])
        for l, band in enumerate(bands)
    ]


def _ir_v(p: Any, m: int, n: int) -> Array:
    """Ivanic–Ruedenberg V term (with the 1998 corrections)."""
    if m == 0:
        return p(1, 1, n) + p(-1, -1, n)
    if m == 1:
        return math.sqrt(2.0) * p(1, 0, n)
    if m == -1:
        return math.sqrt(2.0) * p(-1, 0, n)
    if m > 0:
        return p(1, m - 1, n) - p(-1, 1 - m, n)
    return p(1, m + 1, n) + p(-1, -m - 1, n)


def _ir_w(p: Any, m: int, n: int) -> Array:
    """Ivanic–Ruedenberg W term (only needed where its coefficient is non-zero, m ≠ 0)."""
    if m > 0:
        return p(1, m + 1, n) + p(-1, -m - 1, n)
    return p(1, m - 1, n) - p(-1, 1 - m, n)


def sh_rotation_matrix(rotation: Array, order: int) -> Array:
    r"""Block-diagonal matrix D that rotates SH coefficients of degree ``≤ order`` by ``rotation``.

    With ``c' = D @ c`` the expansion of ``c'`` is the function rotated by R:
    :math:`f'(\omega) = f(R^{\mathsf T}\omega)`, i.e. ``reconstruct(c', R @ ω) ==
    reconstruct(c, ω)``. Each band is computed by the Ivanic–Ruedenberg recurrence (with the
    1998 corrections) from the band-1 matrix, which for our convention is R with its axes
    permuted to (y, z, x). The matrix is orthogonal and polynomial in R's entries, so gradients
    flow to ``rotation``.

    Parameters
    ----------
    rotation : array (3, 3)
        Proper rotation matrix.
    order : int
        Maximum degree ``l``.

    Returns
    -------
    array ((order + 1)**2, (order + 1)**2)

    References
    ----------
    .. [1] J. Ivanic and K. Ruedenberg, "Rotation matrices for real spherical harmonics. Direct
       determination by recursion", J. Phys. Chem. 100(15), 1996, pp. 6342–6347, and the
       additions and corrections in J. Phys. Chem. A 102(45), 1998, pp. 9099–9100.

    Examples
    --------
    >>> import numpy as np
    >>> quarter_turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> D = sh_rotation_matrix(quarter_turn, 2)
    >>> D.shape, bool(np.allclose(D @ D.T, np.eye(9)))
    ((9, 9), True)
    """
    order = _check_order(order)
    rotation = _check_rotation(rotation)
    xp = namespace(rotation)
    n = (order + 1) ** 2
    rows = []
    for l, block in enumerate(_band_rotations(rotation, order)):
        start, size = l * l, 2 * l + 1
        left = xp.zeros((size, start), dtype=rotation.dtype, device=device(rotation))
        right = xp.zeros((size, n - start - size), dtype=rotation.dtype, device=device(rotation))
        rows.append(xp.concat([left, block, right], axis=1))
    return xp.concat(rows, axis=0)


def rotate_sh(coeffs: Array, rotation: Array) -> Array:
    r"""SH coefficients of the function rotated by R, :math:`f'(\omega) = f(R^{\mathsf T}\omega)`.

    Parameters
    ----------
    coeffs : array ((order + 1)**2, C)
        Coefficients at index ``l(l+1) + m``.
    rotation : array (3, 3)
        Proper rotation matrix R.

    Returns
    -------
    array ((order + 1)**2, C)
        ``sh_rotation_matrix(R, order) @ coeffs``; ``reconstruct(result, R @ ω)`` equals
        ``reconstruct(coeffs, ω)``.

    References
    ----------
    .. [1] J. Ivanic and K. Ruedenberg, J. Phys. Chem. 100(15), 1996, pp. 6342–6347.

    Examples
    --------
    A quarter turn about z takes the function x to y:

    >>> import numpy as np
    >>> quarter_turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> x = np.zeros((4, 1))
    >>> x[sh_index(1, 1)] = 1.0
    >>> rotate_sh(x, quarter_turn).round(12)[:, 0].tolist() == [0.0, 1.0, 0.0, 0.0]
    True
    """
    xp = namespace(coeffs, rotation)
    coeffs = asarray(coeffs, xp)
    order = _order_of(coeffs)
    dtype = float_dtype(xp, coeffs, rotation)
    matrix = sh_rotation_matrix(asarray(rotation, xp, like=coeffs, dtype=dtype), order)
    return xp.matmul(matrix, asarray(coeffs, xp, like=matrix))
