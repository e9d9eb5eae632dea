r"""Diffuse/specular separation: the dichromatic model, from one image or a polariser pair.

Dichromatic reflection (Shafer 1985; Klinker, Shafer & Kanade 1988): the colour of a
dielectric is the sum of a body (diffuse) term with the object's chromaticity Λ and an
interface (specular) term with the illuminant's chromaticity Γ,

.. math:: I_c = m_d\,\Lambda_c + m_s\,\Gamma_c, \qquad
          \textstyle\sum_c \Lambda_c = \sum_c \Gamma_c = 1,

with geometric factors :math:`m_d, m_s \ge 0`. After dividing each channel by :math:`3\Gamma_c`
(white balance) the illuminant is white, :math:`\Gamma_c = 1/3`, and

- the *specular-free image* :math:`I_c - \min_k I_k` (Tan & Ikeuchi 2005; Yoon et al. 2006)
  has no specular term but the wrong colour: it keeps the diffuse *geometry*;
- knowing the diffuse *maximum chromaticity* :math:`\Lambda_{\max} = \max_c \Lambda_c` of a
  pixel gives the exact split: :math:`\max_c I_c - \bar I = m_d (\Lambda_{\max} - 1/3)`, so
  :math:`m_d = (\max_c I_c - \bar I)/(\Lambda_{\max} - 1/3)` and the specular part of every
  channel is :math:`(\sum_c I_c - m_d)/3` (Tan & Ikeuchi's specular-to-diffuse mechanism).
  Yang, Wang & Ahuja (2010) estimate :math:`\Lambda_{\max}` by propagating it from diffuse
  pixels into highlights with a joint bilateral filter (:func:`separate_dichromatic`).

Polarisation (Wolff & Boult 1991; Nayar, Fang & Boult 1997; the lectures' "linear polarising
filters on the camera and light source"): with a polarised light, specular reflection keeps the
polarisation while body reflection is depolarised, so a camera polariser crossed with the
light's blocks the specular and half the diffuse light: diffuse :math:`= 2 I_\perp`, specular
:math:`= I_\parallel - I_\perp` (:func:`separate_polarization`).

All images are linear (radiance), ``(H, W, 3)`` float arrays; NumPy in, NumPy out.

References
----------
.. [1] S. A. Shafer, "Using color to separate reflection components", Color Research &
   Application 10(4), 1985, pp. 210–218.
.. [2] G. J. Klinker, S. A. Shafer and T. Kanade, "The measurement of highlights in color
   images", IJCV 2(1), 1988, pp. 7–32.
.. [3] R. T. Tan and K. Ikeuchi, "Separating reflection components of textured surfaces using a
   single image", IEEE TPAMI 27(2), 2005, pp. 178–193.
.. [4] Q. Yang, S. Wang and N. Ahuja, "Real-time specular highlight removal using bilateral
   filtering", ECCV 2010, pp. 87–100.
.. [5] K.-J. Yoon, Y. Choi and I. S. Kweon, "Fast separation of reflection components using a
   specularity-invariant image representation", ICIP 2006.
.. [6] S. K. Nayar, X.-S. Fang and T. Boult, "Separation of reflection components using color
   and polarization", IJCV 21(3), 1997, pp. 163–186.
.. [7] L. B. Wolff and T. E. Boult, "Constraining object features using a polarization
   reflectance model", IEEE TPAMI 13(7), 1991.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._array import check_param
from brdfkit._checks import as_float_array, check_count
from brdfkit.errors import ParameterError

__all__ = [
    "MAX_ITERATIONS",
    "MAX_SIGMA_SPACE",
    "Separation",
    "max_chromaticity",
    "separate_dichromatic",
    "separate_polarization",
    "specular_free",
]


MAX_ITERATIONS = 10_000
"""Largest ``iterations`` of :func:`separate_dichromatic`."""

MAX_SIGMA_SPACE = 64.0
"""Largest ``sigma_space`` (pixels) of :func:`separate_dichromatic`: its filter sums
``(4 σ + 1)²`` shifted images per iteration."""


@dataclass(frozen=True)
class Separation:
    """A split of a linear image into its two reflection components.

    Attributes
    ----------
    diffuse : (H, W, 3) body reflection.
    specular : (H, W, 3) interface reflection; ``diffuse + specular`` is the input image.
    """

    diffuse: np.ndarray
    specular: np.ndarray


def _check_rgb(name: str, image: ArrayLike) -> np.ndarray:
    """``image`` as a finite, non-negative (H, W, 3) float64 array, else a ParameterError."""
    image = as_float_array(name, image, finite=False)
    if image.ndim != 3 or image.shape[-1] != 3:
        raise ParameterError(
            f"{name} must be an RGB image of shape (H, W, 3); got shape {image.shape}"
        )
    if not np.all(np.isfinite(image)) or np.any(image < 0):
        raise ParameterError(f"{name} must hold finite, non-negative linear values")
    return image


def _white_balance(image: np.ndarray, illuminant: ArrayLike | None) -> np.ndarray:
    """Per-channel factors ``3 Γ_c`` that the image is divided by so that Γ becomes white."""
    if illuminant is None:
        return np.ones(3)
    gamma = as_float_array("illuminant", illuminant, finite=False)
    if gamma.shape != (3,) or np.any(gamma <= 0) or not np.all(np.isfinite(gamma)):
        raise ParameterError(
            f"illuminant must be 3 positive numbers (its RGB colour); got {illuminant!r}"
        )
    return 3 * gamma / gamma.sum()


def specular_free(image: ArrayLike, illuminant: ArrayLike | None = None) -> np.ndarray:
    r"""The specular-free image :math:`I_c - \min_k I_k` (after white balance).

    Under a white illuminant the specular term adds the same amount to every channel, which the
    minimum removes: the result depends on :math:`m_d` only (the diffuse shading and texture,
    with a shifted colour). It is the input of chromaticity-based separation and is itself
    useful wherever highlights disturb (stereo, photometric stereo).

    Parameters
    ----------
    image : (H, W, 3) linear RGB.
    illuminant : RGB colour of the light (any scale); white when omitted.

    Returns
    -------
    numpy.ndarray (H, W, 3)
        In the input's white-balanced units multiplied back by the illuminant colour.

    References
    ----------
    .. [1] R. T. Tan and K. Ikeuchi, IEEE TPAMI 27(2), 2005, §4 (the specular-free image).
    .. [2] K.-J. Yoon, Y. Choi and I. S. Kweon, ICIP 2006 (the minimum-subtracted form).

    Examples
    --------
    A white highlight adds the same to every channel; the minimum takes it away:

    >>> import numpy as np
    >>> body = np.array([[[0.5, 0.3, 0.2]]])
    >>> specular_free(body + 0.4).round(12).tolist() == specular_free(body).round(12).tolist()
    True
    >>> specular_free(body).round(12).tolist()
    [[[0.3, 0.1, 0.0]]]
    """
    image = _check_rgb("image", image)
    balance = _white_balance(image, illuminant)
    balanced = image / balance
    return (balanced - balanced.min(axis=-1, keepdims=True)) * balance


def max_chromaticity(image: ArrayLike, *, dark: float = 1e-6) -> np.ndarray:
    r"""Maximum chromaticity :math:`\sigma_{\max} = \max_c I_c / \sum_c I_c` of every pixel.

    Pixels whose channel sum is at most ``dark`` get 1/3 (achromatic).

    References
    ----------
    .. [1] R. T. Tan and K. Ikeuchi, IEEE TPAMI 27(2), 2005, eq. 6.

    Examples
    --------
    >>> import numpy as np
    >>> max_chromaticity(np.array([[[0.5, 0.3, 0.2], [0.0, 0.0, 0.0]]])).round(4).tolist()
    [[0.5, 0.3333]]
    """
    image = _check_rgb("image", image)
    total = image.sum(axis=-1)
    return np.where(total > dark, image.max(axis=-1) / np.maximum(total, dark), 1.0 / 3.0)


def _joint_bilateral(
    values: np.ndarray, guide: np.ndarray, sigma_space: float, sigma_range: float
) -> np.ndarray:
    """Joint (cross) bilateral filter of a 2-D ``values`` guided by ``guide`` (same shape).

    A Gaussian spatial kernel of radius ⌈2σ_s⌉ times a Gaussian of the guide's differences.
    OpenCV's ``jointBilateralFilter`` lives in the contrib package that brdfkit does not depend
    on, hence this small shifted-sum implementation.
    """
    radius = max(1, int(np.ceil(2 * sigma_space)))
    padded_values = np.pad(values, radius, mode="edge")
    padded_guide = np.pad(guide, radius, mode="edge")
    height, width = values.shape
    total = np.zeros_like(values)
    weights = np.zeros_like(values)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            window = (
                slice(radius + dy, radius + dy + height),
                slice(radius + dx, radius + dx + width),
            )
            w = np.exp(
                -(dx * dx + dy * dy) / (2 * sigma_space**2)
                - (padded_guide[window] - guide) ** 2 / (2 * sigma_range**2)
            )
            total += w * padded_values[window]
            weights += w
    return total / weights


def separate_dichromatic(
    image: ArrayLike,
    illuminant: ArrayLike | None = None,
    *,
    sigma_space: float = 3.0,
    sigma_range: float = 0.04,
    iterations: int = 50,
    tolerance: float = 1e-4,
    dark: float = 1e-4,
) -> Separation:
    r"""Single-image diffuse/specular separation (Yang, Wang & Ahuja 2010).

    1. White-balance by the ``illuminant`` colour so that :math:`\Gamma_c = 1/3`.
    2. :math:`\lambda_c = (I_c - \min I)/(\sum I - 3\min I)`, the chromaticity of the
       specular-free image, whose maximum :math:`\lambda_{\max}` equals the diffuse maximum
       chromaticity :math:`\Lambda_{\max}` at diffuse pixels and is close to it at specular
       ones (exactly so for two-colour-dominant pixels).
    3. Estimate :math:`\Lambda_{\max}` as the maximum chromaticity :math:`\sigma_{\max}` of the
       image, raised iteratively to its joint-bilateral filtering guided by
       :math:`\lambda_{\max}`: :math:`\sigma \leftarrow \max(\sigma, \mathrm{JBF}(\sigma;
       \lambda_{\max}))` until it changes by less than ``tolerance``. Highlights lower
       σ (they are whiter), the filter carries the diffuse value in from neighbours of the same
       surface colour.
    4. :math:`m_d = (\max_c I_c - \bar I)/(\sigma - 1/3)`, specular per channel
       :math:`(\sum_c I_c - m_d)/3` (clamped to ``[0, min_c I_c]``), diffuse = image − specular;
       then undo the white balance.

    Achromatic (grey) surfaces, :math:`\Lambda_{\max} = 1/3`, cannot be separated by colour:
    their pixels, and those darker than ``dark`` (channel sum), are returned as diffuse.

    Parameters
    ----------
    image : (H, W, 3) linear RGB.
    illuminant : RGB colour of the light (any scale); white when omitted.
    sigma_space, sigma_range : the joint bilateral filter's spatial (pixels) and range
        (chromaticity) standard deviations.
    iterations, tolerance : stopping rule of step 3 (at most :data:`MAX_ITERATIONS`).
    dark : channel sum below which a pixel is left diffuse.

    Returns
    -------
    Separation

    Raises
    ------
    brdfkit.errors.ParameterError
        ``image`` not a finite, non-negative (H, W, 3) array; a bad ``illuminant``;
        ``sigma_space`` outside (0, :data:`MAX_SIGMA_SPACE`], ``sigma_range`` not finite and
        positive, ``tolerance`` or ``dark`` not finite and >= 0.
    brdfkit.errors.ResourceError
        ``iterations`` above :data:`MAX_ITERATIONS`.

    References
    ----------
    .. [1] Q. Yang, S. Wang and N. Ahuja, "Real-time specular highlight removal using bilateral
       filtering", ECCV 2010, §3–4.
    .. [2] R. T. Tan and K. Ikeuchi, IEEE TPAMI 27(2), 2005, eqs. 10–12.
    .. [3] G. J. Klinker, S. A. Shafer and T. Kanade, IJCV 2(1), 1988.
    """
    image = _check_rgb("image", image)
    check_param("sigma_space", sigma_space, 0.0, MAX_SIGMA_SPACE, lo_open=True)
    check_param("sigma_range", sigma_range, 0.0, lo_open=True)
    check_param("tolerance", tolerance, 0.0)
    check_param("dark", dark, 0.0)
    iterations = check_count("iterations", iterations, MAX_ITERATIONS)
    balance = _white_balance(image, illuminant)
    balanced = image / balance
    total = balanced.sum(axis=-1)
    minimum = balanced.min(axis=-1)
    chromatic = total - 3 * minimum
    valid = (total > dark) & (chromatic > dark * 1e-3)
    lam = np.where(
        valid[..., None],
        (balanced - minimum[..., None]) / np.where(valid, chromatic, 1.0)[..., None],
        1.0 / 3.0,
    ).max(axis=-1)
    sigma = np.where(valid, balanced.max(axis=-1) / np.where(valid, total, 1.0), 1.0 / 3.0)
    for _ in range(iterations):
        filtered = _joint_bilateral(sigma, lam, sigma_space, sigma_range)
        updated = np.maximum(sigma, filtered)
        converged = np.max(np.abs(updated - sigma)) < tolerance
        sigma = updated
        if converged:
            break
    separable = valid & (sigma > 1.0 / 3.0 + 1e-6)
    m_d = (balanced.max(axis=-1) - total / 3) / np.where(separable, sigma - 1.0 / 3.0, 1.0)
    specular = np.where(separable, np.clip((total - m_d) / 3, 0.0, minimum), 0.0)
    specular = specular[..., None] * balance
    return Separation(image - specular, specular)


def separate_polarization(parallel: ArrayLike, crossed: ArrayLike) -> Separation:
    r"""Diffuse and specular components from a parallel and a crossed polariser image.

    With a linearly polarised light, specular (interface) reflection keeps the polarisation and
    body reflection is depolarised. Through a camera polariser parallel to the light's one sees
    :math:`I_\parallel = D/2 + S`, crossed :math:`I_\perp = D/2`, so

    .. math:: D = 2 I_\perp, \qquad S = I_\parallel - I_\perp

    (``S`` clamped at 0 against noise; the diffuse part then absorbs the difference so that
    ``D + S = I_∥ + I_⊥``, the unpolarised image).

    Parameters
    ----------
    parallel, crossed : (H, W, C) linear images of the same view.

    Returns
    -------
    Separation
        Whose sum is the unpolarised image :math:`I_\parallel + I_\perp`.

    References
    ----------
    .. [1] L. B. Wolff and T. E. Boult, IEEE TPAMI 13(7), 1991.
    .. [2] S. K. Nayar, X.-S. Fang and T. Boult, IJCV 21(3), 1997, §2.
    .. [3] P. Debevec et al., "Acquiring the reflectance field of a human face", SIGGRAPH 2000,
       §2.2 (cross-polarised capture).
    """
    parallel = as_float_array("parallel", parallel, finite=False)
    crossed = as_float_array("crossed", crossed, finite=False)
    if parallel.ndim != 3 or parallel.shape != crossed.shape:
        raise ParameterError(
            "parallel and crossed must be images of the same shape (H, W, C); got "
            f"{parallel.shape} and {crossed.shape}"
        )
    for name, value in (("parallel", parallel), ("crossed", crossed)):
        if not np.all(np.isfinite(value)) or np.any(value < 0):
            raise ParameterError(f"{name} must hold finite, non-negative linear values")
    specular = np.maximum(parallel - crossed, 0.0)
    return Separation(parallel + crossed - specular, specular)
