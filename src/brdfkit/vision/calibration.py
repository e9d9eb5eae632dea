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
import warnings
from collections.abc import Callable, Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._array import check_param
from brdfkit._checks import as_float_array, check_count, check_memory
from brdfkit.errors import FormatError, ParameterError
from brdfkit.io import (
    ImageNotFoundError,
    ImageReadError,
    read_image,
    srgb_decode,
    without_alpha,
)

__all__ = [
    "LEVELS",
    "LINEAR_SUFFIXES",
    "MAX_SAMPLES",
    "hat_weights",
    "linearize",
    "merge_hdr",
    "read_exposure_time",
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

    Examples
    --------
    >>> import numpy as np
    >>> linear = linearize(np.array([0.5, 1.0]), "srgb")
    >>> linear.dtype, [round(float(value), 4) for value in linear]
    (dtype('float32'), [0.214, 1.0])
    """
    image = np.asarray(image, dtype=np.float32)
    if encoding == "linear":
        return image
    if encoding == "srgb":
        return srgb_decode(image)
    raise ParameterError(f"encoding must be 'linear' or 'srgb'; got {encoding!r}")


def read_linear_image(path: str | os.PathLike, encoding: Encoding | None = None) -> np.ndarray:
    """Read an image as linear radiance, refusing to guess the encoding of 8/16-bit files.

    ``.hdr`` and ``.exr`` files are linear by definition (``encoding`` must then be ``None``
    or ``"linear"``). PNG, TIFF, JPEG, TGA and BMP store *encoded* codes: ``encoding`` must say
    whether they are sRGB-encoded photos (``"srgb"``, decoded) or already linear data
    (``"linear"``). Alpha channels are dropped.

    Raises
    ------
    brdfkit.errors.ParameterError
        An 8/16-bit image without ``encoding`` (a non-linear image where a linear one is
        required), or ``"srgb"`` for an HDR file.
    brdfkit.io.ImageReadError
        The file is missing or cannot be decoded (a :class:`~brdfkit.errors.FormatError`).

    References
    ----------
    .. [1] IEC 61966-2-1:1999.
    """
    suffix = os.fspath(path).lower().rsplit(".", 1)[-1]
    image = without_alpha(read_image(path))
    if f".{suffix}" in LINEAR_SUFFIXES:
        if encoding == "srgb":
            raise ParameterError(
                f"encoding must be 'linear' (or omitted) for {path}: .{suffix} stores linear "
                "radiance; got 'srgb'"
            )
        return image
    if encoding is None:
        raise ParameterError(
            f"{path} is an 8/16-bit .{suffix} image, whose values are usually sRGB-encoded "
            "(non-linear); this needs linear radiance: say encoding='srgb' to decode it, "
            "encoding='linear' if it holds linear values, or give an .hdr/.exr file"
        )
    return linearize(image, encoding)


_EXIF_IFD, _EXPOSURE_TIME = 0x8769, 0x829A
"""The Exif sub-IFD's pointer tag and its ExposureTime tag (seconds, a rational)."""


def read_exposure_time(path: str | os.PathLike) -> float | None:
    """The exposure time (seconds) a photo's Exif metadata records, or ``None`` if it records
    none (or the file has no Exif block).

    Read with Pillow: the ExposureTime tag of the Exif sub-IFD, or of the first IFD where a
    writer put it there.

    Raises
    ------
    brdfkit.io.ImageReadError
        The file is missing or not an image Pillow can open.
    brdfkit.errors.FormatError
        The tag holds no positive, finite number of seconds.

    References
    ----------
    CIPA DC-008-2019, *Exif Version 2.32*, §4.6.5 (ExposureTime, tag 33434).

    Examples
    --------
    A JPEG that records 1/250 s:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from PIL import Image
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "shot.jpg"
    ...     exif = Image.Exif()
    ...     exif.get_ifd(0x8769)[0x829A] = 1 / 250
    ...     Image.new("RGB", (4, 4)).save(path, exif=exif)
    ...     read_exposure_time(path)
    0.004
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            exif = image.getexif()
            value = exif.get_ifd(_EXIF_IFD).get(_EXPOSURE_TIME, exif.get(_EXPOSURE_TIME))
    except FileNotFoundError as error:
        raise ImageNotFoundError(path, "no such file") from error
    except (OSError, UnidentifiedImageError) as error:
        raise ImageReadError(path, f"cannot read it as an image ({error})") from error
    if value is None:
        return None
    try:
        seconds = float(value)
    except (TypeError, ValueError, ZeroDivisionError):
        seconds = float("nan")
    if not (np.isfinite(seconds) and seconds > 0):
        raise FormatError(path, f"its Exif ExposureTime is {value!r}, not a positive time")
    return seconds


def hat_weights(levels: int = 256) -> np.ndarray:
    r"""Debevec & Malik's hat weighting :math:`w(z) = z - z_{\min}` for
    :math:`z \le \tfrac12(z_{\min} + z_{\max})`, :math:`z_{\max} - z` above.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``levels`` is not an integer >= 3.
    brdfkit.errors.ResourceError
        ``levels`` exceeds 65536 (16-bit codes).

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, eq. 4.

    Examples
    --------
    >>> hat_weights(5).tolist()
    [0.0, 1.0, 2.0, 1.0, 0.0]
    """
    levels = check_count("levels", levels, 2**16, minimum=3)
    z = np.arange(levels, dtype=np.float64)
    return np.minimum(z, levels - 1 - z)


MAX_SAMPLES = 100_000
"""Most pixels :func:`recover_response` may sample (its system has ``256 + samples`` unknowns)."""

LEVELS = 256
"""Codes of an 8-bit image."""


def _check_stack(
    images: Sequence[ArrayLike] | np.ndarray, times: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """The stack as (P, H, W, C) uint8 and the times as (P,) float64, validated.

    Raises
    ------
    brdfkit.errors.ParameterError
        Images of different shapes, not 8-bit, fewer than 2 or empty; times not one finite,
        positive number per image.
    """
    if not isinstance(images, np.ndarray):
        shapes = [np.shape(image) for image in images]
        for k, shape in enumerate(shapes):
            if shape != shapes[0]:
                raise ParameterError(
                    f"images must all have the same shape; image {k} is {shape}, image 0 is "
                    f"{shapes[0]}"
                )
    stack = np.asarray(images)
    if stack.ndim == 3:
        stack = stack[..., None]
    if stack.ndim != 4 or 0 in stack.shape:
        raise ParameterError(
            f"images must be a stack of shape (P, H, W) or (P, H, W, C); got {stack.shape}"
        )
    if stack.shape[0] < 2:
        raise ParameterError(f"an exposure stack needs at least 2 images; got {stack.shape[0]}")
    times = as_float_array("times", times, finite=False)
    if times.shape != (stack.shape[0],) or not np.all(np.isfinite(times) & (times > 0)):
        raise ParameterError(
            f"times must be {stack.shape[0]} finite, positive exposure times (one per image); "
            f"got {times.tolist()}"
        )
    if stack.dtype != np.uint8:
        raise ParameterError(
            f"images must be 8-bit codes (uint8, as a camera writes them); got dtype "
            f"{stack.dtype}: linear or HDR images need no response recovery"
        )
    _check_equal_times(stack, times)
    return stack, times


SAME_EXPOSURE_CODES = 1.0
"""How far (in codes) the mean codes of two images of one exposure time may differ: repeated
shots differ by noise, which averages out over the image; a mislabelled time shifts the mean
by tens of codes."""


def _check_equal_times(stack: np.ndarray, times: np.ndarray) -> None:
    """Raise unless images with equal exposure times show the same exposure."""
    means = stack.reshape(stack.shape[0], -1).mean(axis=1)
    for j in range(times.size):
        for k in range(j):
            if times[j] == times[k] and abs(means[j] - means[k]) > SAME_EXPOSURE_CODES:
                raise ParameterError(
                    f"times gives images {k} and {j} the same exposure time {times[j]:g} s, but "
                    f"their mean codes differ ({means[k]:.1f} vs {means[j]:.1f}): equal times "
                    "must show equal exposures (is a time mislabelled?)"
                )


def sample_pixels(
    images: Sequence[ArrayLike] | np.ndarray, samples: int = 200, seed: int = 0
) -> np.ndarray:
    """Pixel indices for :func:`recover_response`, spread over the scene's brightness.

    Debevec & Malik need pixels whose radiances cover the range and that are well exposed in
    some image; here the flat pixel indices are drawn stratified by the mean code of the middle
    exposure (equal counts per code quantile), which covers dark and bright pixels alike.

    Parameters
    ----------
    images : (P, H, W) or (P, H, W, C) exposure stack.
    samples : number of pixels, 2 … :data:`MAX_SAMPLES` (fewer when the image has fewer).
    seed : of the draw within each stratum.

    Returns
    -------
    numpy.ndarray (samples,) of flat indices into an (H, W) image.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``samples`` is not an integer >= 2, or the stack is not (P, H, W[, C]).
    brdfkit.errors.ResourceError
        ``samples`` exceeds :data:`MAX_SAMPLES`.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, §2.1 (choosing the sample pixels).
    """
    samples = check_count("samples", samples, MAX_SAMPLES, minimum=2)
    stack = np.asarray(images)
    if stack.ndim == 3:
        stack = stack[..., None]
    if stack.ndim != 4 or 0 in stack.shape:
        raise ParameterError(
            f"images must be a stack of shape (P, H, W) or (P, H, W, C); got {stack.shape}"
        )
    middle = stack[len(stack) // 2].astype(np.float64).mean(axis=-1).ravel()
    samples = min(samples, middle.size)
    order = np.argsort(middle, kind="stable")
    rng = np.random.default_rng(seed)
    strata = np.array_split(order, samples)
    return np.array([rng.choice(stratum) for stratum in strata])


def _solve_channel(
    codes: np.ndarray, log_times: np.ndarray, smoothness: float, channel: int
) -> np.ndarray:
    """gsolve for one channel: ``g`` (256,) from the (count, P) codes of well-exposed pixels.

    Raises
    ------
    brdfkit.errors.ParameterError
        The system is singular: the exposures do not determine the response.
    """
    from scipy import sparse
    from scipy.sparse.linalg import MatrixRankWarning, spsolve

    weights = hat_weights(LEVELS)
    count, n_images = codes.shape
    n_equations = count * n_images
    z = np.arange(1, LEVELS - 1)
    w = weights[codes].ravel()
    data_rows = np.arange(n_equations)
    smooth_rows = n_equations + 1 + np.arange(LEVELS - 2)
    rows = np.concatenate([data_rows, data_rows, [n_equations], np.tile(smooth_rows, 3)])
    columns = np.concatenate(
        [
            codes.ravel(),
            LEVELS + np.repeat(np.arange(count), n_images),
            [LEVELS // 2],  # the gauge g(128) = 0
            z - 1,
            z,
            z + 1,
        ]
    )
    smooth = smoothness * weights[z]
    values = np.concatenate([w, -w, [1.0], smooth, -2 * smooth, smooth])
    a = sparse.csr_matrix(
        (values, (rows, columns)), shape=(n_equations + LEVELS - 1, LEVELS + count)
    )
    b = np.zeros(a.shape[0])
    b[:n_equations] = (weights[codes] * log_times).ravel()
    # The normal equations of this small, well-posed system (sparse and exact).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MatrixRankWarning)  # reported below as an error
        solution = spsolve((a.T @ a).tocsc(), a.T @ b)
    if not np.all(np.isfinite(solution)):
        raise ParameterError(
            f"the camera response of channel {channel} is numerically undetermined by these "
            "exposures (use closer exposure times or sample more pixels)"
        )
    return solution[:LEVELS]


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
    ``z = 1 … 254``. The system is regular when some sampled pixel is well exposed at two
    different codes (which fixes the slope that the smoothness term leaves free). A sampled
    pixel that is never well exposed (codes 0 or 255 in every image:
    zero weight everywhere) says nothing about ``g`` and would leave its :math:`\ln E_i`
    undetermined, so it is left out of that channel's system.

    Parameters
    ----------
    images : (P, H, W) or (P, H, W, C) uint8 exposure stack of a static scene.
    times : (P,) exposure times in seconds, finite and positive.
    smoothness : λ > 0 (the codes 0 and 255 have zero weight and are fixed by it alone).
    samples : number of pixels sampled (:func:`sample_pixels`), at most :data:`MAX_SAMPLES`;
        Debevec & Malik need ``samples·(P − 1) > 256``.
    seed : of the pixel sampling.

    Returns
    -------
    numpy.ndarray (256, C)
        ``g`` per code and channel, with ``g(128) = 0``; always finite.

    Raises
    ------
    brdfkit.errors.ParameterError
        A bad stack or times (:func:`merge_hdr`), ``smoothness`` not finite and positive, too
        few well-exposed samples, or exposures that do not determine the response.
    brdfkit.errors.ResourceError
        ``samples`` exceeds :data:`MAX_SAMPLES`.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, §2.1 and the appendix (gsolve.m).
    """
    stack, times = _check_stack(images, times)
    check_param("smoothness", smoothness, 0.0, lo_open=True)
    pixels = sample_pixels(stack, samples, seed)
    n_images = stack.shape[0]
    weights = hat_weights(LEVELS)
    log_times = np.log(times)
    responses = []
    for channel in range(stack.shape[-1]):
        codes = stack[..., channel].reshape(n_images, -1)[:, pixels].T  # (count, P)
        codes = codes[weights[codes].sum(axis=1) > 0]  # drop never well-exposed pixels
        if len(codes) * (n_images - 1) < LEVELS:
            raise ParameterError(
                f"samples·(images − 1) must exceed 256 for the response to be determined; got "
                f"{len(codes)}·{n_images - 1} ({pixels.size - len(codes)} of the {pixels.size} "
                f"sampled pixels are never well exposed in channel {channel}): sample more pixels"
            )
        well, wide = weights[codes] > 0, codes.astype(np.int16)
        spread = np.where(well, wide, LEVELS).min(axis=1) < np.where(well, wide, -1).max(axis=1)
        if not spread.any():  # else g + b·z (any slope b) fits as well: a singular system
            raise ParameterError(
                f"the exposures do not determine the camera response of channel {channel}: no "
                "sampled pixel is well exposed at two different codes (use closer exposure "
                "times or sample more pixels)"
            )
        responses.append(_solve_channel(codes, log_times, smoothness, channel))
    return np.stack(responses, axis=-1)


def _check_response(response: ArrayLike, channels: int) -> np.ndarray:
    """``response`` as a finite (256, channels) array."""
    response = as_float_array("response", response)
    if response.ndim == 1:
        response = response[:, None]
    if response.ndim != 2 or response.shape[0] != LEVELS or response.shape[1] not in (1, channels):
        raise ParameterError(
            f"response must have shape (256,) or (256, {channels}); got {response.shape}"
        )
    return np.broadcast_to(response, (LEVELS, channels))


def _fallback_exposure(stack: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Per pixel and channel, the exposure a pixel with no well-exposed code is read from.

    The shortest exposure in which it is saturated (code 255: the tightest lower bound on its
    radiance), or, never saturated, the longest (it is 0 in all: the tightest upper bound).
    """
    order = np.argsort(times, kind="stable")
    saturated = stack[order] == LEVELS - 1
    return np.where(saturated.any(axis=0), order[saturated.argmax(axis=0)], order[-1])


MERGE_CHUNK = 1 << 22
"""Values (pixels times channels) :func:`merge_hdr` merges at a time."""


def merge_hdr(
    images: Sequence[ArrayLike] | np.ndarray,
    times: ArrayLike,
    response: ArrayLike,
    *,
    return_mask: bool = False,
    callback: Callable[[int, int], None] | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    r"""Radiance map from an exposure stack and a log inverse response ``g`` (Debevec–Malik).

    .. math:: \ln E_i = \frac{\sum_j w(Z_{ij})\,(g(Z_{ij}) - \ln\Delta t_j)}{\sum_j w(Z_{ij})}

    with the hat weights of :func:`hat_weights`. A pixel with no well-exposed code (0 or 255 in
    every image of a channel) has no weight; it falls back to a single exposure: the shortest
    one in which it is saturated (always-saturated pixels: the shortest exposure, whose
    :math:`g(255) - \ln\Delta t` is the tightest lower bound on the radiance), or, if it is
    never saturated, the longest exposure (always-black pixels: the tightest upper bound).
    ``return_mask=True`` also returns which pixels fell back.

    Parameters
    ----------
    images : (P, H, W) or (P, H, W, C) uint8 stack.
    times : (P,) exposure times in seconds, finite and positive.
    response : (256, C) or (256,) finite log inverse response (:func:`recover_response`).
    return_mask : also return the fallback mask.
    callback : ``callback(rows_done, rows)`` after each chunk of rows (:data:`MERGE_CHUNK`
        values at a time: the memory stays a few bytes per value however many exposures).

    Returns
    -------
    radiance : numpy.ndarray (H, W, C) float32
        Linear radiance, in the units fixed by the response's gauge; finite.
    fallback_mask : numpy.ndarray (H, W) bool
        Only with ``return_mask``: pixels with no well-exposed code in at least one channel.

    Raises
    ------
    brdfkit.errors.ParameterError
        Images of different shapes, not uint8 or fewer than 2; times not one finite, positive
        number per image; a response of the wrong shape, not finite, or so large that the
        radiance overflows float32.
    brdfkit.errors.ResourceError
        The merge would not fit in the memory available.

    References
    ----------
    .. [1] P. E. Debevec and J. Malik, SIGGRAPH 1997, eq. 6.
    """
    stack, times = _check_stack(images, times)
    response = _check_response(response, stack.shape[-1])
    height, width, channels = stack.shape[1:]
    # The radiance (float32), the fallback mask, and one chunk's six float64 sums and gathers.
    values = height * width * channels
    check_memory(f"merging a {stack.shape} exposure stack", 5 * values + 48 * MERGE_CHUNK)
    weights = hat_weights(LEVELS)
    weighted = weights[:, None] * response  # w(z) g(z) per code and channel
    radiance = np.empty((height, width, channels), np.float32)
    fell_back = np.zeros((height, width), bool)
    rows = max(1, MERGE_CHUNK // (width * channels))
    for top in range(0, height, rows):
        chunk = stack[:, top : top + rows]
        log_merged, lit = _merge_chunk(chunk, times, response, weights, weighted)
        if log_merged.max() >= np.log(np.finfo(np.float32).max):
            raise ParameterError(
                f"response is too large: the radiance exp({log_merged.max():.4g}) overflows float32"
            )
        radiance[top : top + rows] = np.exp(log_merged)
        fell_back[top : top + rows] = ~np.all(lit, axis=-1)
        if callback is not None:
            callback(min(top + rows, height), height)
    return (radiance, fell_back) if return_mask else radiance


def _merge_chunk(
    chunk: np.ndarray,
    times: np.ndarray,
    response: np.ndarray,
    weights: np.ndarray,
    weighted: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The log radiance of a ``(P, h, W, C)`` chunk of the stack (:func:`merge_hdr`'s
    formula, its sums gathered from the tables ``w(z)`` and ``w(z) g(z)`` one exposure at a
    time), and where some code was well exposed ``(h, W, C)``."""
    channel = np.arange(chunk.shape[-1])
    numerator = np.zeros(chunk.shape[1:])
    total = np.zeros(chunk.shape[1:])
    for codes, log_time in zip(chunk, np.log(times), strict=True):
        w = weights[codes]
        numerator += weighted[codes, channel] - w * log_time
        total += w
    lit = total > 0
    log_merged = numerator / np.where(lit, total, 1.0)
    if not lit.all():
        dark = chunk[:, ~lit]  # (P, K): the codes of the values no exposure showed well
        exposure = _fallback_exposure(dark, times)
        codes = np.take_along_axis(dark, exposure[None], 0)[0]
        log_merged[~lit] = response[codes, np.nonzero(~lit)[-1]] - np.log(times)[exposure]
    return log_merged, lit
