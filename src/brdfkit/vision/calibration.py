r"""Radiometric calibration: linearising photos, camera response recovery, HDR merging.

A camera maps the exposure :math:`X = E\,\Delta t` (irradiance times exposure time) through an
unknown monotonic response to a pixel code, :math:`Z = f(E\,\Delta t)`. With
:math:`g = \ln f^{-1}`, every pixel ``i`` of every exposure ``j`` gives
:math:`g(Z_{ij}) = \ln E_i + \ln \Delta t_j`. Debevec & Malik (1997) solve these equations for
the 256 values of ``g`` and the unknown :math:`\ln E_i` of a few sampled pixels in the least-
squares sense, with a hat weighting :math:`w(Z)` that trusts mid-range codes, a smoothness
penalty :math:`\lambda \sum w(z)\,g''(z)^2` and the gauge :math:`g(128) = 0`
(:func:`recover_response`); then each pixel's radiance is the weighted average
:math:`\ln E_i = \sum_j w(Z_{ij})(g(Z_{ij}) - \ln\Delta t_j)/\sum_j w(Z_{ij})`
(:func:`merge_hdr`). The radiance is known up to one global scale (the gauge).

Images that went through a standard sRGB pipeline are linearised with the IEC 61966-2-1 curve
instead (:func:`brdfkit.io.srgb_decode`); :func:`linearize` and :func:`read_linear_image`
make that choice explicit, so that no non-linear image reaches an algorithm that needs radiance.

References
----------
.. [1] P. E. Debevec and J. Malik, "Recovering high dynamic range radiance maps from
   photographs", SIGGRAPH 1997, pp. 369–378 (the gsolve program of its appendix).
.. [2] S. Mann and R. W. Picard, "On being 'undigital' with digital cameras: extending dynamic
   range by combining differently exposed pictures", IS&T 48th annual conference, 1995.
.. [3] IEC 61966-2-1:1999 (sRGB).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from brdfkit.io import read_image, srgb_decode

__all__ = [
    "LINEAR_SUFFIXES",
    "hat_weights",
    "linearize",
    "merge_hdr",
    "read_linear_image",
    "recover_response",
    "sample_pixels",
]

LINEAR_SUFFIXES = (".hdr", ".exr")
"""File formats that store linear radiance; every other format stores encoded codes."""

Encoding = Literal["linear", "srgb"]


def linearize(image: ArrayLike, encoding: Encoding) -> np.ndarray:
    """Linear values from an image stored with ``encoding`` (``"srgb"`` or ``"linear"``).

    ``"srgb"`` applies the IEC 61966-2-1 decoding (:func:`brdfkit.io.srgb_decode`) to the
    colour channels; ``"linear"`` returns the values unchanged.

    References
    ----------
    .. [1] IEC 61966-2-1:1999, §5.2.
    """
    image = np.asarray(image, dtype=np.float32)
    if encoding == "linear":
        return image
    if encoding == "srgb":
        return srgb_decode(image)
    raise ValueError(f"encoding must be 'linear' or 'srgb'; got {encoding!r}")


def read_linear_image(path: str | os.PathLike, encoding: Encoding | None = None) -> np.ndarray:
    """Read an image as linear radiance, refusing to guess the encoding of 8/16-bit files.

    ``.hdr`` and ``.exr`` files are linear by definition (``encoding`` must then be ``None``
    or ``"linear"``). PNG, TIFF, JPEG, TGA and BMP store *encoded* codes: ``encoding`` must say
    whether they are sRGB-encoded photos (``"srgb"``, decoded) or already linear data
    (``"linear"``). Alpha channels are dropped.

    Raises
    ------
    ValueError
        An 8/16-bit image without ``encoding`` (a non-linear image where a linear one is
        required), or ``"srgb"`` for an HDR file.

    References
    ----------
    .. [1] IEC 61966-2-1:1999.
    """
    suffix = os.fspath(path).lower().rsplit(".", 1)[-1]
    image = read_image(path)
    if image.shape[-1] in (2, 4):
        image = image[..., :-1]
    if f".{suffix}" in LINEAR_SUFFIXES:
        if encoding == "srgb":
            raise ValueError(
                f"encoding must be 'linear' (or omitted) for {path}: .{suffix} stores linear "
                "radiance; got 'srgb'"
            )
        return image
    if encoding is None:
        raise ValueError(
            f"{path} is an 8/16-bit .{suffix} image, whose values are usually sRGB-encoded "
            "(non-linear); this needs linear radiance: say encoding='srgb' to decode it, "
            "encoding='linear' if it holds linear values, or give an .hdr/.exr file"
        )
    return linearize(image, encoding)


def hat_weights(levels: int = 256) -> np.ndarray:
    r"""Debevec & Malik's hat weighting :math:`w(z) = z - z_{\min}` for
    :math:`z \le \tfrac12(z_{\min} + z_{\max})`, :math:`z_{\max} - z` above.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, eq. 4.
    """
    if isinstance(levels, bool) or not isinstance(levels, int) or levels < 3:
        raise ValueError(f"levels must be an integer >= 3; got {levels!r}")
    z = np.arange(levels, dtype=np.float64)
    return np.minimum(z, levels - 1 - z)


def _check_stack(images: Sequence[ArrayLike] | np.ndarray, times: ArrayLike) -> tuple:
    stack = np.asarray(images)
    times = np.asarray(times, dtype=np.float64)
    if stack.ndim == 3:
        stack = stack[..., None]
    if stack.ndim != 4:
        raise ValueError(
            f"images must be a stack of shape (P, H, W) or (P, H, W, C); got {stack.shape}"
        )
    if stack.shape[0] < 2:
        raise ValueError(f"an exposure stack needs at least 2 images; got {stack.shape[0]}")
    if times.shape != (stack.shape[0],) or np.any(times <= 0) or not np.all(np.isfinite(times)):
        raise ValueError(
            f"times must be {stack.shape[0]} positive exposure times (one per image); "
            f"got {times.tolist()}"
        )
    if stack.dtype != np.uint8:
        raise ValueError(
            f"images must be 8-bit codes (uint8, as a camera writes them); got dtype "
            f"{stack.dtype}: linear or HDR images need no response recovery"
        )
    return stack, times


def sample_pixels(
    images: Sequence[ArrayLike] | np.ndarray, samples: int = 200, seed: int = 0
) -> np.ndarray:
    """Pixel indices for :func:`recover_response`, spread over the scene's brightness.

    Debevec & Malik need pixels whose radiances cover the range and that are well exposed in
    some image; here the flat pixel indices are drawn stratified by the mean code of the middle
    exposure (equal counts per code quantile), which covers dark and bright pixels alike.

    Returns
    -------
    numpy.ndarray (samples,) of flat indices into an (H, W) image.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, §2.1 (choosing the sample pixels).
    """
    stack = np.asarray(images)
    if stack.ndim == 3:
        stack = stack[..., None]
    middle = stack[len(stack) // 2].astype(np.float64).mean(axis=-1).ravel()
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 2:
        raise ValueError(f"samples must be an integer >= 2; got {samples!r}")
    samples = min(samples, middle.size)
    order = np.argsort(middle, kind="stable")
    rng = np.random.default_rng(seed)
    strata = np.array_split(order, samples)
    return np.array([rng.choice(stratum) for stratum in strata])


def recover_response(
    images: Sequence[ArrayLike] | np.ndarray,
    times: ArrayLike,
    *,
    smoothness: float = 50.0,
    samples: int = 200,
    seed: int = 0,
) -> np.ndarray:
    r"""The log inverse response :math:`g(z) = \ln f^{-1}(z)` of each channel (Debevec–Malik).

    Solves, per channel and in the least-squares sense (sparse normal equations), the system of
    gsolve: for sampled pixels ``i`` and images ``j``,
    :math:`w(Z_{ij})\,[g(Z_{ij}) - \ln E_i] = w(Z_{ij}) \ln\Delta t_j`; the gauge
    :math:`g(128) = 0`; and :math:`\lambda\,w(z)\,[g(z-1) - 2g(z) + g(z+1)] = 0` for
    ``z = 1 … 254``.

    Parameters
    ----------
    images : (P, H, W) or (P, H, W, C) uint8 exposure stack of a static scene.
    times : (P,) exposure times in seconds.
    smoothness : λ.
    samples : number of pixels sampled (:func:`sample_pixels`); Debevec & Malik need
        ``samples·(P − 1) > 256``.
    seed : of the pixel sampling.

    Returns
    -------
    numpy.ndarray (256, C)
        ``g`` per code and channel, with ``g(128) = 0``.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, §2.1 and the appendix (gsolve.m).
    """
    stack, times = _check_stack(images, times)
    if not smoothness >= 0:
        raise ValueError(f"smoothness must be >= 0; got {smoothness!r}")
    levels = 256
    weights = hat_weights(levels)
    pixels = sample_pixels(stack, samples, seed)
    count, n_images = pixels.size, stack.shape[0]
    if count * (n_images - 1) < levels:
        raise ValueError(
            f"samples·(images − 1) must exceed 256 for the response to be determined; got "
            f"{count}·{n_images - 1}: sample more pixels"
        )
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    log_times = np.log(times)
    n_equations = count * n_images
    z = np.arange(1, levels - 1)
    responses = []
    for channel in range(stack.shape[-1]):
        codes = stack[..., channel].reshape(n_images, -1)[:, pixels].T  # (count, P)
        w = weights[codes].ravel()
        data_rows = np.arange(n_equations)
        smooth_rows = n_equations + 1 + np.arange(levels - 2)
        rows = np.concatenate([data_rows, data_rows, [n_equations], np.tile(smooth_rows, 3)])
        columns = np.concatenate(
            [
                codes.ravel(),
                levels + np.repeat(np.arange(count), n_images),
                [levels // 2],  # the gauge g(128) = 0
                z - 1,
                z,
                z + 1,
            ]
        )
        smooth = smoothness * weights[z]
        values = np.concatenate([w, -w, [1.0], smooth, -2 * smooth, smooth])
        a = sparse.csr_matrix(
            (values, (rows, columns)), shape=(n_equations + levels - 1, levels + count)
        )
        b = np.zeros(a.shape[0])
        b[:n_equations] = (weights[codes] * log_times).ravel()
        # The normal equations of this small, well-posed system (sparse and exact).
        solution = spsolve((a.T @ a).tocsc(), a.T @ b)
        responses.append(solution[:levels])
    return np.stack(responses, axis=-1)


def merge_hdr(
    images: Sequence[ArrayLike] | np.ndarray, times: ArrayLike, response: ArrayLike
) -> np.ndarray:
    r"""Radiance map from an exposure stack and a log inverse response ``g`` (Debevec–Malik).

    .. math:: \ln E_i = \frac{\sum_j w(Z_{ij})\,(g(Z_{ij}) - \ln\Delta t_j)}{\sum_j w(Z_{ij})}

    with the hat weights of :func:`hat_weights`. A pixel saturated (or black) in every image
    has no weight; it takes the value of the exposure whose code is nearest mid-range.

    Parameters
    ----------
    images : (P, H, W) or (P, H, W, C) uint8 stack.
    times : (P,) exposure times in seconds.
    response : (256, C) or (256,) log inverse response (:func:`recover_response`).

    Returns
    -------
    numpy.ndarray (H, W, C) float32
        Linear radiance, in the units fixed by the response's gauge.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, eq. 6.
    """
    stack, times = _check_stack(images, times)
    response = np.asarray(response, dtype=np.float64)
    if response.ndim == 1:
        response = response[:, None]
    if response.shape[0] != 256 or response.shape[1] not in (1, stack.shape[-1]):
        raise ValueError(
            f"response must have shape (256,) or (256, {stack.shape[-1]}); got {response.shape}"
        )
    response = np.broadcast_to(response, (256, stack.shape[-1]))
    weights = hat_weights(256)[stack]
    channel = np.arange(stack.shape[-1])
    log_radiance = response[stack, channel] - np.log(times)[:, None, None, None]
    total = weights.sum(axis=0)
    merged = (weights * log_radiance).sum(axis=0) / np.where(total > 0, total, 1.0)
    best = np.abs(stack.astype(np.int16) - 127).argmin(axis=0)
    fallback = np.take_along_axis(log_radiance, best[None], axis=0)[0]
    return np.exp(np.where(total > 0, merged, fallback)).astype(np.float32)
