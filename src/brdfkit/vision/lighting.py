r"""Illumination from an image: 9-term SH lighting, a dominant directional light, mirror balls.

A convex Lambertian object of albedo ρ with known normals ``n`` under distant lighting
``L(ω)`` shows the radiance

.. math:: B(n) = \frac{\rho}{\pi} E(n)
          = \frac{\rho}{\pi} \sum_{l \le 2} \sum_m \hat A_l L_{lm} Y_{lm}(n),

linear in the nine lighting coefficients :math:`L_{lm}` (Ramamoorthi & Hanrahan 2001: the
clamped-cosine kernel :math:`\hat A_l` keeps more than 99% of the energy of any lighting in the
bands ``l ≤ 2``). :func:`estimate_sh_lighting` solves that linear system by least squares; with
an unknown constant albedo leave ``albedo=1`` and the result is :math:`\rho L_{lm}`: the
lighting up to one scale (Basri & Jacobs 2003). :func:`estimate_directional_light` fits a
single distant light, :math:`B = \tfrac{\rho}{\pi} E \max(n\cdot l, 0)`, by least squares on the
lit pixels, re-deciding which pixels are in attached shadow from the current estimate.
:func:`mirror_ball_to_latlong` turns the photograph of a mirror ball into a lat-long
environment map (the geometry is :meth:`brdfkit.light.EnvironmentMap.from_mirror_ball`; this
adds locating the ball from its mask).

Frames: normals, coefficients and directions share whatever frame the normals are given in
(the camera frame x right, y up, z towards the camera of :mod:`brdfkit.vision`, or the world
frame of :mod:`brdfkit.render`); the SH convention is :mod:`brdfkit.light.spherical_harmonics`'s.

References
----------
.. [1] R. Ramamoorthi and P. Hanrahan, "An efficient representation for irradiance environment
   maps", SIGGRAPH 2001; "On the relationship between radiance and irradiance: determining the
   illumination from images of a convex Lambertian object", JOSA A 18(10), 2001.
.. [2] R. Basri and D. W. Jacobs, "Lambertian reflectance and linear subspaces", IEEE TPAMI
   25(2), 2003.
.. [3] P. Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 1998 (light probes).
.. [4] CMU 16-385 Lecture 14 (9-term SH lighting; directional lights).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._array import Array, asarray, check_finite, holds_normal, namespace, to_numpy
from brdfkit._checks import as_float_array, check_count, check_memory
from brdfkit.errors import ParameterError
from brdfkit.light.spherical_harmonics import lambertian_kernel, sh_basis

__all__ = [
    "MAX_ITERATIONS",
    "MAX_LATLONG_HEIGHT",
    "DirectionalLightEstimate",
    "estimate_directional_light",
    "estimate_sh_lighting",
    "mirror_ball_to_latlong",
]

MAX_LATLONG_HEIGHT = 8192
"""Largest lat-long ``height`` of :func:`mirror_ball_to_latlong` (``width`` at most twice it)."""

MAX_ITERATIONS = 10_000
"""Largest ``iterations`` of :func:`estimate_directional_light`."""

_LATLONG_BYTES_PER_PIXEL = 160
"""Peak bytes per lat-long pixel of :meth:`~brdfkit.light.EnvironmentMap.from_mirror_ball`
(directions, normals and sampling tables), plus 8 per channel: 125 for a 512 × 1024 map of 1 or
3 channels, by ``tracemalloc``."""


def _check_image_normals(
    image: Array, normals: Array, mask: Array | None
) -> tuple[Array, Array, Array]:
    """``image`` as (H, W, C), ``normals`` (H, W, 3) and the bool mask (H, W), validated.

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, or NaN or infinity in ``image`` or ``normals``.
    """
    xp = namespace(image, normals)
    image = asarray(image, xp)
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim != 3:
        raise ParameterError(
            f"image must have shape (H, W) or (H, W, C); got shape {tuple(image.shape)}"
        )
    normals = asarray(normals, xp, like=image)
    if tuple(normals.shape) != (*image.shape[:2], 3):
        raise ParameterError(
            f"normals must have shape {(*image.shape[:2], 3)} to match the image; "
            f"got shape {tuple(normals.shape)}"
        )
    length = xp.sqrt(xp.sum(normals * normals, axis=-1))
    if mask is None:
        mask = holds_normal(normals)
    else:
        mask = asarray(mask, xp)
        if tuple(mask.shape) != tuple(image.shape[:2]):
            raise ParameterError(
                f"mask must have shape {tuple(image.shape[:2])}; got shape {tuple(mask.shape)}"
            )
        mask = xp.astype(mask, xp.bool) & (length > 0)
    return check_finite("image", image), check_finite("normals", normals), mask


def _check_albedo(albedo: float | ArrayLike, channels: int) -> np.ndarray:
    """``albedo`` as (channels,) float64: finite, positive, a scalar or one per channel."""
    albedo_np = as_float_array("albedo", to_numpy(albedo))
    if albedo_np.ndim > 1 or albedo_np.size not in (1, channels) or not np.all(albedo_np > 0):
        raise ParameterError(
            f"albedo must be a finite, positive number or one per channel ({channels}); "
            f"got {albedo!r}"
        )
    return np.broadcast_to(albedo_np, (channels,))


def estimate_sh_lighting(
    image: Array, normals: Array, mask: Array | None = None, albedo: float | ArrayLike = 1.0
) -> Array:
    r"""Nine SH lighting coefficients per channel from an image of a convex Lambertian object.

    Least squares over the masked pixels ``p`` of

    .. math:: B_p = \frac{\rho}{\pi}\sum_{k<9} \hat A_{l(k)}\, Y_k(n_p)\, L_k

    with :math:`\hat A_l = \pi, 2\pi/3, \pi/4`
    (:func:`brdfkit.light.spherical_harmonics.lambertian_kernel`), solved per channel by a QR
    factorisation of the ``P × 9`` design matrix. The nine functions are
    linearly independent on any open patch of the sphere, so the normals a single view sees
    (a hemisphere) determine all nine coefficients, but less stably than the whole sphere does.

    Parameters
    ----------
    image : array (H, W, C) or (H, W)
        Linear radiance of the object.
    normals : array (H, W, 3)
        Unit normals; pixels outside ``mask`` are ignored.
    mask : array (H, W) of bool, optional
        Pixels to use; by default those whose normal has length > 0.5.
    albedo : float or (C,)
        Known constant albedo ρ. With an unknown albedo leave 1: the result is then ρ·L_lm,
        the lighting up to a scale.

    Returns
    -------
    array (9, C)
        Radiance coefficients ``L_lm`` in :mod:`brdfkit.light.spherical_harmonics`'s convention,
        same backend and dtype as ``image``; ``brdfkit.light.spherical_harmonics.irradiance_sh(L,
        n) * ρ / π`` re-renders the image.

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, NaN or infinity in ``image`` or ``normals``, an ``albedo`` that
        is not finite and positive, or fewer than 9 pixels.

    References
    ----------
    .. [1] R. Ramamoorthi and P. Hanrahan, "On the relationship between radiance and
       irradiance", JOSA A 18(10), 2001, §5 (lighting from a convex Lambertian object).
    .. [2] R. Basri and D. W. Jacobs, "Lambertian reflectance and linear subspaces", IEEE TPAMI
       25(2), 2003, §4.
    """
    image, normals, mask = _check_image_normals(image, normals, mask)
    xp = namespace(image)
    albedo_c = _check_albedo(albedo, image.shape[-1])
    pixels = image[mask]
    if pixels.shape[0] < 9:
        raise ParameterError(
            f"mask must select at least 9 pixels to fit 9 SH coefficients; got {pixels.shape[0]}"
        )
    kernel = np.repeat(lambertian_kernel(2), [1, 3, 5]) / math.pi
    design = sh_basis(normals[mask], 2) * asarray(kernel, like=image, dtype=image.dtype)
    q, r = xp.linalg.qr(design)
    coeffs = xp.linalg.solve(r, xp.matmul(xp.permute_dims(q, (1, 0)), pixels))
    return coeffs / asarray(albedo_c, like=coeffs, dtype=coeffs.dtype)


@dataclass(frozen=True)
class DirectionalLightEstimate:
    """A distant light fitted to a Lambertian image.

    Attributes
    ----------
    direction : (3,) unit direction towards the light, in the normals' frame.
    irradiance : (C,) irradiance E on a surface facing the light (for the given albedo).
    lit : (H, W) bool, the pixels used in the final fit (in the mask, not in attached shadow).
    rms : relative RMS residual of the fit over the lit pixels (residual / RMS of the image).
    """

    direction: np.ndarray
    irradiance: np.ndarray
    lit: np.ndarray
    rms: float


def estimate_directional_light(
    image: ArrayLike,
    normals: ArrayLike,
    mask: ArrayLike | None = None,
    albedo: float | ArrayLike = 1.0,
    *,
    shadow_threshold: float = 0.05,
    iterations: int = 10,
) -> DirectionalLightEstimate:
    r"""The dominant distant light of a Lambertian image, by least squares on the lit pixels.

    On the pixels in light, the channel mean :math:`\bar B_p = n_p \cdot s` with
    :math:`s = \tfrac{\bar\rho}{\pi} \bar E\, l` is linear in ``s``; its least-squares solution
    gives the direction :math:`l = s/|s|`. Pixels in attached shadow (:math:`n\cdot l \le 0`)
    obey :math:`B = 0`, not :math:`B = n\cdot s`, and would bias the fit, so the lit set starts
    as the pixels brighter than ``shadow_threshold`` times the image's maximum and is then
    re-decided as those with :math:`n\cdot l > 0` as well, until it stops changing. Each
    channel's irradiance then follows from :math:`B_c = \tfrac{\rho_c}{\pi} E_c (n\cdot l)`.

    Parameters
    ----------
    image : (H, W, C) or (H, W) linear radiance.
    normals : (H, W, 3) unit normals.
    mask : (H, W) bool, optional; by default the pixels whose normal has length > 0.5.
    albedo : known albedo ρ (scalar or per channel); 1 when unknown (``irradiance`` is then ρE).
    shadow_threshold : brightness, relative to the maximum, below which a pixel starts as shadow.
    iterations : maximum number of re-decisions of the lit set, at most
        :data:`MAX_ITERATIONS`.

    Returns
    -------
    DirectionalLightEstimate

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, NaN or infinity in ``image`` or ``normals``, an ``albedo`` that
        is not finite and positive, an empty mask, or an image too dark to fit.
    brdfkit.errors.ResourceError
        ``iterations`` above :data:`MAX_ITERATIONS`.

    Examples
    --------
    A Lambertian sphere (albedo 0.6) lit with irradiance 1 from 37° to the right:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.vision.photometric_stereo import sphere_normals
    >>> from brdfkit.vision.synthesis import render_brdf
    >>> normals, inside = sphere_normals((9, 9), centre=(4.0, 4.0), radius=4.5)
    >>> light = np.array([[0.6, 0.0, 0.8]])
    >>> image = render_brdf(normals, inside, light, Lambertian(rho=0.6))[0]
    >>> estimate = estimate_directional_light(image, normals, inside, albedo=0.6)
    >>> estimate.direction.round(6).tolist(), estimate.irradiance.round(6).tolist()
    ([0.6, -0.0, 0.8], [1.0])

    References
    ----------
    .. [1] B. K. P. Horn, *Robot Vision*, MIT Press 1986, §10.6 (Lambertian reflectance map).
    .. [2] Y. Zhang and Y.-H. Yang, "Multiple illuminant direction detection with application
       to image synthesis", IEEE TPAMI 23(8), 2001 (lit-pixel least squares on a sphere).
    """
    if not 0 <= shadow_threshold < 1:
        raise ParameterError(f"shadow_threshold must be in [0, 1); got {shadow_threshold!r}")
    iterations = check_count("iterations", iterations, MAX_ITERATIONS)
    image, normals, mask = (
        to_numpy(a) for a in _check_image_normals(as_float_array("image", image), normals, mask)
    )
    albedo_np = _check_albedo(albedo, image.shape[-1])
    if not mask.any():
        raise ParameterError("mask selects no pixel with a normal")
    gray = image.mean(axis=-1)
    lit = mask & (gray > shadow_threshold * gray[mask].max())
    for _ in range(iterations):
        if lit.sum() < 3:
            raise ParameterError(
                "fewer than 3 lit pixels: the image is dark or shadow_threshold too high "
                f"(shadow_threshold={shadow_threshold})"
            )
        s, *_ = np.linalg.lstsq(normals[lit], gray[lit], rcond=None)
        if not np.linalg.norm(s) > 0:
            raise ParameterError("the image is black on every lit pixel: no light to estimate")
        direction = s / np.linalg.norm(s)
        new_lit = lit & (normals @ direction > 0)
        if np.array_equal(new_lit, lit):
            break
        lit = new_lit
    shading = normals[lit] @ direction
    scale = shading @ image[lit] / (shading @ shading)
    residual = image[lit] - shading[:, None] * scale
    rms = float(np.sqrt(np.mean(residual**2)) / np.sqrt(np.mean(image[lit] ** 2)))
    return DirectionalLightEstimate(direction, math.pi * scale / albedo_np, lit, rms)


def mirror_ball_to_latlong(
    photo: ArrayLike, mask: ArrayLike | None = None, *, height: int = 256, width: int = 512
) -> np.ndarray:
    r"""A lat-long environment map from the photograph of a mirror ball.

    With ``mask`` the ball's disc is located by :func:`brdfkit.vision.photometric_stereo.
    fit_circle` (centre and radius from the mask's moments) and the photo is resampled
    bilinearly to the square that circumscribes it; without, ``photo`` must already be that
    square. :meth:`brdfkit.light.EnvironmentMap.from_mirror_ball` then maps every lat-long
    direction ``d`` to the ball point whose normal :math:`n = (d + v)/|d + v|` reflects the
    view direction ``v`` into ``d`` (orthographic view). Its frame: world +z is the photo's
    up, +x points towards the camera, +y to the photo's right. Directions right behind the ball
    (``d ≈ −v``) are seen only at the rim and come out blurred.

    Parameters
    ----------
    photo : (H, W, C) linear image of the ball.
    mask : (H, W) bool, optional: the ball's pixels.
    height, width : size of the lat-long map; ``height`` at most :data:`MAX_LATLONG_HEIGHT`,
        ``width`` at most twice that.

    Returns
    -------
    numpy.ndarray (height, width, C)
        Radiance in :mod:`brdfkit.light.spherical_harmonics`'s lat-long convention.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``photo`` not a finite, non-negative (H, W[, C]) image, a ``mask`` of another shape or
        empty, or a size below 1 (2 for the height).
    brdfkit.errors.ResourceError
        A size above its maximum, or a map that would not fit in the memory available.

    References
    ----------
    .. [1] P. Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 1998, §3.
    .. [2] G. S. Miller and C. R. Hoffman, "Illumination and reflection maps", SIGGRAPH 1984
       course notes.
    """
    from scipy.ndimage import map_coordinates

    from brdfkit.light.environment import EnvironmentMap
    from brdfkit.vision.photometric_stereo import fit_circle

    height = check_count("height", height, MAX_LATLONG_HEIGHT, minimum=2)
    width = check_count("width", width, 2 * MAX_LATLONG_HEIGHT)
    photo = as_float_array("photo", to_numpy(photo))
    if photo.ndim == 2:
        photo = photo[..., None]
    if photo.ndim != 3:
        raise ParameterError(f"photo must have shape (H, W) or (H, W, C); got shape {photo.shape}")
    if min(photo.shape) < 1 or min(photo.shape[:2]) < 2:
        raise ParameterError(f"photo must be at least 2 × 2 pixels; got shape {photo.shape}")
    check_memory(
        f"a {height} × {width} lat-long map",
        height * width * (_LATLONG_BYTES_PER_PIXEL + 8 * photo.shape[2]),
    )
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != photo.shape[:2]:
            raise ParameterError(f"mask must have shape {photo.shape[:2]}; got shape {mask.shape}")
        c_x, c_y, radius = fit_circle(mask)
        size = max(2, round(2 * radius))
        # Pixel centres of a size × size square spanning [c - r, c + r] in the photo.
        offsets = (np.arange(size) + 0.5) * (2 * radius / size) - radius - 0.5
        rows, cols = np.meshgrid(c_y + offsets, c_x + offsets, indexing="ij")
        photo = np.stack(
            [
                map_coordinates(photo[..., c], [rows, cols], order=1, mode="nearest")
                for c in range(photo.shape[2])
            ],
            axis=-1,
        )
    if np.any(photo < 0) or not np.all(np.isfinite(photo)):
        raise ParameterError("photo must hold finite, non-negative linear radiance")
    return EnvironmentMap.from_mirror_ball(photo, height=height, width=width).image
