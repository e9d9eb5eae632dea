"""Photometric-stereo images of given normals under distant lights, for any BRDF.

Image formation (orthographic camera looking down -z, distant light ``l_k`` of irradiance
``E_k`` at normal incidence, unit normal ``n``)::

    I_k = f_r(w_i, w_o) E_k max(0, n . l_k)

with ``w_i = l_k`` and ``w_o = (0, 0, 1)`` expressed in the pixel's local frame (z the normal,
x the image's x made orthogonal to it: the tangent of anisotropic models runs along the rows).
Only attached shadows (``n . l_k <= 0``) darken a pixel; nothing casts shadows on a normal map.

References
----------
.. [1] F. E. Nicodemus, J. C. Richmond, J. J. Hsia, I. W. Ginsberg, T. Limperis, "Geometrical
   considerations and nomenclature for reflectance", NBS Monograph 160, 1977 (the BRDF).
.. [2] R. J. Woodham, "Photometric method for determining surface orientation from multiple
   images", Optical Engineering 19(1), 1980.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import as_float_array, check_memory
from brdfkit.brdf.base import BRDF
from brdfkit.errors import ParameterError
from brdfkit.geometry import frame_from_normal, to_local
from brdfkit.vision.datasets import PhotometricStereoData


def _frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local frames ``(s, t, n)`` with ``s`` the image x (the image y where x is too close to
    the normal) made orthogonal to ``n``."""
    axis = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    return frame_from_normal(normals, tangent=axis)


def render_brdf(
    normals: ArrayLike,
    mask: ArrayLike,
    light_directions: ArrayLike,
    brdf: BRDF,
    *,
    irradiance: ArrayLike = 1.0,
) -> np.ndarray:
    """Radiance images ``I_k = f_r E_k max(0, n·l_k)`` (module docstring) of the mask pixels.

    Parameters
    ----------
    normals : (H, W, 3) unit normals (x right, y up, z towards the camera).
    mask : (H, W) bool; images are 0 outside.
    light_directions : (N, 3) directions towards the lights (normalised here).
    brdf : any BRDF of the protocol (analytic, a sum, measured).
    irradiance : ``E_k``, a scalar or (N,) per light.

    Returns
    -------
    (N, H, W, C) float64 radiance, ``C = brdf.channels``.

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, non-finite values, a light with ``z <= 0`` (behind the camera's
        side), or a negative irradiance.
    brdfkit.errors.ResourceError
        Images that would not fit in memory.

    Examples
    --------
    A Lambertian plane facing the camera, lit head-on and at 60°:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> normals = np.broadcast_to([0.0, 0.0, 1.0], (2, 2, 3))
    >>> lights = np.array([[0.0, 0.0, 1.0], [np.sqrt(3) / 2, 0.0, 0.5]])
    >>> images = render_brdf(normals, np.ones((2, 2), bool), lights, Lambertian(rho=0.5))
    >>> images.shape, (images[:, 0, 0, 0] * np.pi).round(12).tolist()  # ρ cos θ
    ((2, 2, 2, 1), [0.5, 0.25])
    """
    normals = as_float_array("normals", normals)
    mask = np.asarray(mask, dtype=bool)
    lights = as_float_array("light_directions", light_directions)
    if normals.ndim != 3 or normals.shape[2] != 3 or mask.shape != normals.shape[:2]:
        raise ParameterError(
            f"normals must be (H, W, 3) and mask (H, W), got {normals.shape} and {mask.shape}"
        )
    if lights.ndim != 2 or lights.shape[1] != 3 or len(lights) < 1:
        raise ParameterError(f"light_directions must be (N, 3), got {lights.shape}")
    lights = lights / np.linalg.norm(lights, axis=1, keepdims=True)
    if not np.all(lights[:, 2] > 0):
        raise ParameterError("every light must be on the camera's side (z > 0)")
    irradiance = np.broadcast_to(as_float_array("irradiance", irradiance), (len(lights),))
    if np.any(irradiance < 0):
        raise ParameterError(f"irradiance must be >= 0, got {irradiance}")
    channels = brdf.channels
    check_memory(
        f"rendering {len(lights)} images of {mask.shape}", 8 * len(lights) * mask.size * channels
    )
    n = normals[mask]
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    frame = _frames(n)
    wo = to_local(np.broadcast_to([0.0, 0.0, 1.0], n.shape), frame)
    images = np.zeros((len(lights), *mask.shape, channels))
    for k, light in enumerate(lights):
        wi = to_local(np.broadcast_to(light, n.shape), frame)
        cos_theta_i = np.clip(wi[:, 2], 0.0, None)
        f = np.broadcast_to(np.asarray(brdf.eval(wi, wo), dtype=np.float64), (len(n), channels))
        images[k][mask] = f * (irradiance[k] * cos_theta_i)[:, None]
    return images


def synthetic_set(
    normals: ArrayLike,
    mask: ArrayLike,
    light_directions: ArrayLike,
    brdf: BRDF,
    *,
    peak: float = 0.9,
    name: str = "synthetic",
) -> PhotometricStereoData:
    """A photometric-stereo data set of :func:`render_brdf` images under unit irradiance,
    recorded at an exposure that puts the brightest pixel at ``peak`` (so that 16-bit files do
    not clip): the raw images are ``s I_k`` and ``light_intensities`` are ``s`` (what the
    loaders divide by), so the loaded images are the radiance ``I_k`` itself.

    Raises
    ------
    brdfkit.errors.ParameterError
        As :func:`render_brdf`; ``peak`` outside (0, 1]; all images black.
    """
    if not 0 < peak <= 1:
        raise ParameterError(f"peak must be in (0, 1], got {peak}")
    mask = np.asarray(mask, dtype=bool)
    images = render_brdf(normals, mask, light_directions, brdf)
    brightest = float(images.max())
    if not brightest > 0:
        raise ParameterError(f"{name}: every image is black (the BRDF reflects nothing here)")
    lights = np.asarray(light_directions, dtype=np.float64)
    lights = lights / np.linalg.norm(lights, axis=1, keepdims=True)
    normals = np.asarray(normals, dtype=np.float64)
    return PhotometricStereoData(
        images=images.astype(np.float32),
        light_directions=lights,
        mask=mask,
        normals=np.where(mask[..., None], normals, 0.0),
        light_intensities=np.full((len(lights), images.shape[3]), peak / brightest),
        name=name,
    )
