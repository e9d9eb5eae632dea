r"""Images (Radiance HDR, OpenEXR, PNG/JPEG/TGA/TIFF), sRGB encoding, tone mapping, data paths.

Reading
-------
:func:`read_image` returns a float32 array of shape (H, W, C), whatever the file:

- ``.hdr`` (Radiance RGBE, read and written here: no lean library has it) and ``.exr``
  (through the OpenEXR bindings): linear radiance values as stored (half floats widened to
  float32).
- ``.png``/``.tif``/``.tiff`` through Pillow, except where Pillow would keep only 8 of 16 bits
  (16-bit PNGs through pypng, 16-bit colour and floating-point TIFFs through tifffile), and
  ``.jpg``/``.jpeg``/``.tga``/``.bmp`` through imageio: integer codes divided by their maximum
  (255 or 65535), i.e. values in [0, 1] *as stored* — sRGB-encoded for ordinary photographs.
  Pass ``srgb_to_linear=True`` to decode them to linear values. Alpha, when present, is
  returned as the last channel and never decoded.

A missing, truncated or corrupt file raises :class:`ImageReadError` (a
:class:`~brdfkit.errors.FormatError`, hence a ``ValueError``) naming the file and the reason.
Files are read into memory in Python and decoded from there (and encoded to memory and written
from Python), so no path ever reaches a native decoder. Before decoding, the size the header
declares (width × height × channels) is checked against :data:`MAX_IMAGE_PIXELS` and the memory
available: a small file that declares a huge image (a "decompression bomb") raises
:class:`ImageTooLargeError` naming the file, having allocated nothing.

Writing
-------
:func:`write_image` writes ``.exr`` (float32 or half), ``.hdr`` (RGBE) and ``.png`` (8 or 16 bits,
sRGB-encoded from linear values by default) atomically: the data goes to a temporary file in the
destination folder, which is then renamed over the destination, so a reader never sees a
half-written image. An image holding NaN or infinity is refused, naming the file, before
anything is written (``nan_marks_missing=True`` lets an EXR mark pixels that have no value);
every failure to write, a full disk or a short write included, names the file too
(:func:`output_failure`).

References
----------
.. [1] IEC 61966-2-1:1999, *Multimedia systems and equipment — Colour measurement and
   management — Part 2-1: Default RGB colour space — sRGB*.
.. [2] G. Ward, "Real pixels", *Graphics Gems II*, 1991 (the RGBE format).
.. [3] F. Kainz, R. Bogart and P. Stanczyk, *Technical Introduction to OpenEXR*, 2013.
.. [4] ITU-R BT.709-6, *Parameter values for the HDTV standards*, 2015 (luminance weights).
"""

from __future__ import annotations

import contextlib
import errno
import io as _io
import os
import sys
import tempfile
from array import array
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit._array import Array, asarray, namespace, to_numpy
from brdfkit._checks import check_memory
from brdfkit.errors import (
    BrdfkitError,
    FormatError,
    OutputError,
    ParameterError,
    ResourceError,
)

__all__ = [
    "MAX_IMAGE_PIXELS",
    "READ_EXTENSIONS",
    "WRITE_EXTENSIONS",
    "ImageNotFoundError",
    "ImageReadError",
    "ImageTooLargeError",
    "atomic_write",
    "atomic_write_bytes",
    "data_path",
    "luminance",
    "output_failure",
    "read_image",
    "read_image_codes",
    "srgb_decode",
    "srgb_encode",
    "tonemap",
    "without_alpha",
    "write_image",
]

READ_EXTENSIONS = (".hdr", ".exr", ".png", ".tif", ".tiff", ".jpg", ".jpeg", ".tga", ".bmp")
"""File extensions :func:`read_image` understands."""

WRITE_EXTENSIONS = (".exr", ".hdr", ".png")
"""File extensions :func:`write_image` understands."""

MAX_IMAGE_PIXELS = 2**27
"""Most pixels (width × height) :func:`read_image` decodes: a 16384 × 8192 light probe, 1.5 GiB
as float32 RGB."""

REC709_WEIGHTS = (0.2126, 0.7152, 0.0722)
"""Rec. 709 / sRGB luminance weights of linear R, G, B."""

# IEC 61966-2-1 piecewise sRGB transfer function.
_SRGB_A = 0.055
_SRGB_GAMMA = 2.4
_SRGB_SLOPE = 12.92
_SRGB_LINEAR_BREAK = 0.0031308
_SRGB_ENCODED_BREAK = 0.04045


class ImageReadError(FormatError):
    """An image file could not be read: the message names the file and the reason."""


class ImageNotFoundError(ImageReadError, FileNotFoundError):
    """The image file does not exist (both a ``FormatError`` and a ``FileNotFoundError``)."""


class ImageTooLargeError(ImageReadError, ResourceError):
    """The image's header declares more pixels than :data:`MAX_IMAGE_PIXELS` or than the memory
    available holds (an ``ImageReadError`` and a :class:`~brdfkit.errors.ResourceError`)."""


# --------------------------------------------------------------------------------------------
# Colour encodings (array API: NumPy, torch, JAX; dtype kept)


def srgb_encode(linear: Array) -> Array:
    r"""sRGB-encode linear values (IEC 61966-2-1 transfer function).

    .. math::

        V = \begin{cases} 12.92\,L & L \le 0.0031308 \\
                          1.055\,L^{1/2.4} - 0.055 & L > 0.0031308 \end{cases}

    Negative inputs are encoded as 0 and values above 1 follow the curve (no clipping).
    Written against the array API (colour-science's ``cctf_encoding`` is NumPy-only) so that
    it runs on torch with gradients.

    Parameters
    ----------
    linear : array (...)
        Linear values.

    Returns
    -------
    array (...)
        Encoded values, in the dtype of ``linear``.

    References
    ----------
    .. [1] IEC 61966-2-1:1999, §5.2, eq. (5).

    Examples
    --------
    Middle grey (18 % reflectance) encodes to about 46 % of full scale:

    >>> import numpy as np
    >>> srgb_encode(np.array([0.0, 0.0031308, 0.18, 1.0])).round(4).tolist()
    [0.0, 0.0404, 0.4614, 1.0]
    >>> float(srgb_decode(srgb_encode(np.float64(0.18))).round(12))
    0.18
    """
    xp = namespace(linear)
    linear = asarray(linear, xp)
    safe = xp.maximum(linear, xp.full_like(linear, _SRGB_LINEAR_BREAK))
    curve = (1 + _SRGB_A) * safe ** (1 / _SRGB_GAMMA) - _SRGB_A
    low = _SRGB_SLOPE * xp.maximum(linear, xp.zeros_like(linear))
    return xp.where(linear <= _SRGB_LINEAR_BREAK, low, curve)


def without_alpha(image: np.ndarray) -> np.ndarray:
    """The colour channels of an ``(H, W, C)`` image: the last channel dropped where ``C`` is 2
    (grey and alpha) or 4 (RGBA), else the image itself."""
    return image[..., :-1] if image.shape[-1] in (2, 4) else image


def srgb_decode(encoded: Array) -> Array:
    r"""Linear values from sRGB-encoded ones (inverse of :func:`srgb_encode`).

    .. math::

        L = \begin{cases} V / 12.92 & V \le 0.04045 \\
                          ((V + 0.055)/1.055)^{2.4} & V > 0.04045 \end{cases}

    Negative inputs decode to 0.

    Parameters
    ----------
    encoded : array (...)
        sRGB-encoded values.

    Returns
    -------
    array (...)
        Linear values, in the dtype of ``encoded``.

    References
    ----------
    .. [1] IEC 61966-2-1:1999, §5.2, eq. (4) (as corrected in Amendment 1, 2003).

    Examples
    --------
    >>> import numpy as np
    >>> srgb_decode(np.array([0.04045, 0.5, 1.0])).round(4).tolist()
    [0.0031, 0.214, 1.0]
    """
    xp = namespace(encoded)
    encoded = asarray(encoded, xp)
    safe = xp.maximum(encoded, xp.full_like(encoded, _SRGB_ENCODED_BREAK))
    curve = ((safe + _SRGB_A) / (1 + _SRGB_A)) ** _SRGB_GAMMA
    low = xp.maximum(encoded, xp.zeros_like(encoded)) / _SRGB_SLOPE
    return xp.where(encoded <= _SRGB_ENCODED_BREAK, low, curve)


def luminance(rgb: Array) -> Array:
    r"""Relative luminance of linear RGB: :math:`Y = 0.2126 R + 0.7152 G + 0.0722 B`.

    Parameters
    ----------
    rgb : array (..., 3)
        Linear Rec. 709 / sRGB primaries.

    Returns
    -------
    array (..., 1)
        Keeps a channel axis of length 1, as every brdfkit result does.

    References
    ----------
    .. [1] ITU-R BT.709-6, item 3.2.

    Examples
    --------
    >>> import numpy as np
    >>> luminance(np.array([[1.0, 1.0, 1.0], [0.0, 1.0, 0.0]])).round(12).tolist()
    [[1.0], [0.7152]]
    """
    xp = namespace(rgb)
    rgb = asarray(rgb, xp)
    if rgb.ndim == 0 or rgb.shape[-1] != 3:
        raise ValueError(
            f"rgb must have a last axis of length 3 (R, G, B); got shape {tuple(rgb.shape)}"
        )
    weights = asarray(REC709_WEIGHTS, xp, like=rgb)
    return xp.sum(rgb * weights, axis=-1, keepdims=True)


TONEMAP_METHODS = ("clip", "reinhard")
"""Tone-mapping operators understood by :func:`tonemap`."""


def tonemap(image: Array, exposure: float = 0.0, method: str = "clip") -> Array:
    r"""Map linear HDR values to displayable linear values in [0, 1].

    The image is first scaled by :math:`2^{\text{exposure}}` (exposure in stops), then

    - ``"clip"``: each channel is clipped to [0, 1];
    - ``"reinhard"``: Reinhard et al.'s global operator on luminance,
      :math:`L_d = L / (1 + L)`, every channel scaled by :math:`L_d / L` (hue kept), then
      clipped to [0, 1]. Needs 3 (RGB) channels; a single channel is its own luminance.

    The result is still linear: :func:`srgb_encode` it for display (``write_image`` does).

    Parameters
    ----------
    image : array (..., C)
        Linear values.
    exposure : float
        Exposure adjustment in stops (powers of two).
    method : {"clip", "reinhard"}

    Returns
    -------
    array (..., C)

    References
    ----------
    .. [1] E. Reinhard, M. Stark, P. Shirley and J. Ferwerda, "Photographic tone reproduction
       for digital images", SIGGRAPH 2002, eq. 3.

    Examples
    --------
    >>> import numpy as np
    >>> tonemap(np.array([0.25, 0.5, 4.0]), exposure=1.0).tolist()  # one stop up, clipped
    [0.5, 1.0, 1.0]
    >>> tonemap(np.array([1.0, 1.0, 1.0]), method="reinhard").tolist()  # L/(1 + L) at L = 1
    [0.5, 0.5, 0.5]
    """
    if method not in TONEMAP_METHODS:
        raise ValueError(f"method must be one of {TONEMAP_METHODS}; got {method!r}")
    if not np.isfinite(exposure):
        raise ValueError(f"exposure must be a finite number of stops; got {exposure!r}")
    xp = namespace(image)
    image = asarray(image, xp) * float(2.0**exposure)
    if method == "reinhard":
        if image.shape[-1] == 3:
            lum = luminance(image)
        elif image.shape[-1] == 1:
            lum = image
        else:
            raise ValueError(
                "image must have 1 or 3 channels for the Reinhard operator; "
                f"got shape {tuple(image.shape)}"
            )
        lum = xp.maximum(lum, xp.zeros_like(lum))
        image = image / (1 + lum)
    return xp.clip(image, 0.0, 1.0)


# --------------------------------------------------------------------------------------------
# Radiance RGBE (.hdr)
#
# Written here because no lean, maintained Python package reads it: imageio's reader needs the
# FreeImage library (a download of its own), Pillow has none, OpenCV is a 180 MB install for
# this one codec. The layout is Ward's [2]_: a text header that ends with a blank line, the
# resolution line ``-Y height +X width``, then scanlines of 4-byte pixels (red, green, blue
# mantissas and a shared exponent), each either flat or run-length encoded channel by channel.
# The conversions are those of Ward's code as distributed by B. Walter (rgbe.c), which OpenCV,
# Mitsuba and stb_image use: a pixel (r, g, b, e) is (r, g, b) · 2^(e − 136), and 0 for e = 0.

_RGBE_FORMAT = b"32-bit_rle_rgbe"
_RGBE_BIAS = 128 + 8
"""Exponent bias plus the 8 bits of the mantissa bytes: value = byte · 2^(e − 136)."""
_RGBE_RLE_WIDTHS = range(8, 0x8000)
"""Scanline widths that may be run-length encoded; narrower and wider ones are always flat."""
_RGBE_MAX_RUN = 128
"""A run-length count byte above 128 repeats one byte (count − 128) times; up to 128 copies
that many literal bytes."""


def _radiance_header(path: Path, data: bytes) -> tuple[int, int, int]:
    """(width, height, offset of the first pixel) of a Radiance file, from its header."""
    if not data.startswith(b"#?"):
        raise ImageReadError(path, "not a Radiance image (it does not begin with '#?')")
    end = data.find(b"\n\n")
    if end < 0:
        raise ImageReadError(path, "not a Radiance image (its header has no end)")
    for line in data[:end].split(b"\n"):
        if line.startswith(b"FORMAT=") and line[7:].strip() != _RGBE_FORMAT:
            found = line[7:].strip().decode("ascii", "replace")
            raise ImageReadError(
                path, f"holds {found} pixels; only {_RGBE_FORMAT.decode()} is read", field="FORMAT"
            )
    line_end = data.find(b"\n", end + 2)
    fields = data[end + 2 : line_end].split() if line_end > 0 else []
    if (
        len(fields) != 4
        or fields[0::2] != [b"-Y", b"+X"]
        or not all(f.isdigit() for f in fields[1::2])
    ):
        line = data[end + 2 : end + 66].split(b"\n", 1)[0].decode("ascii", "replace")
        raise ImageReadError(
            path, f"resolution line {line!r}: expected the standard '-Y height +X width'"
        )
    return int(fields[3]), int(fields[1]), line_end + 1


def _rgbe_pixels(data: bytes, width: int, height: int, start: int) -> np.ndarray:
    """The (height, width, 4) RGBE bytes from ``start``: flat, or run-length encoded scanlines
    (each ``2 2 width_hi width_lo``, then the four channels' runs). Raises ``IndexError`` or
    ``ValueError`` on truncated or corrupt data."""
    first = data[start : start + 4]
    if (
        width not in _RGBE_RLE_WIDTHS
        or len(first) < 4
        or first[:2] != b"\x02\x02"
        or first[2] & 0x80
    ):
        size = width * height * 4
        if len(data) - start < size:
            raise ValueError(f"{len(data) - start} bytes of pixels; {size} expected")
        return np.frombuffer(data, np.uint8, size, start).reshape(height, width, 4)
    stored = np.frombuffer(data, np.uint8)
    markers, runs = _rgbe_runs(data, width, height, start)
    _check_runs(stored, markers, runs, width)
    rows_at_once = max(1, _RGBE_BLOCK_BYTES // (4 * width))
    firsts = range(0, height, rows_at_once)
    bounds = [*np.searchsorted(runs, markers[::rows_at_once]).tolist(), runs.size]
    planes = np.empty((height, 4, width), np.uint8)
    for block, first_row in enumerate(firsts):
        rows = slice(first_row, min(height, first_row + rows_at_once))
        block_runs = runs[bounds[block] : bounds[block + 1]]
        planes[rows] = _expand_runs(stored, markers[rows], block_runs).reshape(-1, 4, width)
    return planes.transpose(0, 2, 1)


_RGBE_RUN_LENGTHS = [c - _RGBE_MAX_RUN if c > _RGBE_MAX_RUN else c for c in range(256)]
"""The pixels a run with count byte c stands for: c − 128 copies of one byte, or c literals."""
_RGBE_RUN_STRIDES = [2 if c > _RGBE_MAX_RUN else 1 + c for c in range(256)]
"""The bytes a run with count byte c takes in the file: the count and one byte, or c + 1."""

_RGBE_BLOCK_BYTES = 1 << 16
"""Run-length scanlines are expanded this many bytes at a time: ``np.repeat``'s counts become
an array of indices eight times as large, small enough here to be reused from block to
block rather than touched fresh (slow on first touch) for a whole map."""


def _rgbe_runs(data: bytes, width: int, height: int, at: int) -> tuple[np.ndarray, np.ndarray]:
    """The offsets of the ``height`` scanline markers and of their runs' count bytes, the
    first row beginning at ``at`` (int64 arrays, gathered in C-level ``array`` buffers: a list
    of 50,000 Python ints costs more to convert than to fill): the one sequential pass over
    the file. A row's runs must fill its four channels exactly (:func:`_check_runs`)."""
    marker = bytes([2, 2, width >> 8, width & 0xFF])
    markers, runs = array("q"), array("q")
    add_marker, add_run = markers.append, runs.append
    lengths, strides = _RGBE_RUN_LENGTHS, _RGBE_RUN_STRIDES
    for row in range(height):
        if data[at : at + 4] != marker:
            raise ValueError(f"scanline {row} does not begin with {list(marker)}")
        add_marker(at)
        at += 4
        left = 4 * width
        while left > 0:
            count = data[at]
            add_run(at)
            left -= lengths[count]
            at += strides[count]
        if left:
            raise ValueError(f"scanline {row} runs past its width {width}")
    if at > len(data):
        raise ValueError(f"the last run of scanline {height - 1} runs past the file's end")
    return np.frombuffer(markers, np.int64), np.frombuffer(runs, np.int64)


def _check_runs(stored: np.ndarray, markers: np.ndarray, runs: np.ndarray, width: int) -> None:
    """Raise ``ValueError`` unless every run (whose rows' four channels' runs fill them, as
    :func:`_rgbe_runs` made sure) has a length and lies within one channel: the runs' ends,
    counted from the first row's start, meet every multiple of ``width`` (found by bisection:
    the ends increase)."""
    counts = stored[runs].astype(np.int64)
    lengths = np.where(counts > _RGBE_MAX_RUN, counts - _RGBE_MAX_RUN, counts)
    empty = np.flatnonzero(lengths == 0)
    if empty.size:
        row = np.searchsorted(markers, runs[empty[0]], side="right") - 1
        raise ValueError(f"scanline {row} has a run of length 0")
    ends = np.cumsum(lengths)
    channels = np.arange(width, ends[-1] + 1, width)
    met = ends[np.minimum(np.searchsorted(ends, channels), ends.size - 1)] == channels
    if not met.all():
        row = np.flatnonzero(~met)[0] // 4
        raise ValueError(f"scanline {row} has a run across channels")


def _expand_runs(stored: np.ndarray, markers: np.ndarray, runs: np.ndarray) -> np.ndarray:
    """The bytes that scanlines stand for, given the offsets of their markers and of their
    runs' count bytes (in order, back to back), by one ``np.repeat`` of the span of the file
    they cover: each byte of it is repeated as often as it stands in the image — a marker's
    and a count byte none, a literal's bytes once, a run's byte (after a count above 128)
    ``count − 128`` times."""
    counts = stored[runs]
    repeated = counts > _RGBE_MAX_RUN
    begin = int(markers[0])
    end = int(runs[-1]) + (2 if repeated[-1] else 1 + int(counts[-1]))
    times = np.ones(end - begin, np.uint8)
    times[(markers[:, None] + np.arange(4) - begin).ravel()] = 0
    times[runs - begin] = 0
    times[runs[repeated] + 1 - begin] = counts[repeated] - _RGBE_MAX_RUN
    return np.repeat(stored[begin:end], times)


def _rgbe_to_float(rgbe: np.ndarray) -> np.ndarray:
    """float32 RGB (H, W, 3), C-contiguous, of RGBE bytes: (r, g, b) · 2^(e − 136), 0 where
    e = 0 (exact: an 8-bit mantissa times a power of two is a float32). Channel by channel:
    run-length encoded scanlines expand to planes (a channel's bytes side by side), read in
    place."""
    scales = np.ldexp(np.float32(1), np.arange(256) - _RGBE_BIAS).astype(np.float32)
    scales[0] = 0
    exponent = scales[rgbe[..., 3]]
    rgb = np.empty((*rgbe.shape[:-1], 3), np.float32)
    for channel in range(3):
        np.multiply(rgbe[..., channel], exponent, out=rgb[..., channel])
    return rgb


def _float_to_rgbe(rgb: np.ndarray) -> np.ndarray:
    """RGBE bytes (H, W, 4) of non-negative RGB: the largest component's binary exponent is
    shared, each mantissa truncated to 8 bits (Ward's ``float2rgbe``; ~1 % precision)."""
    peak = rgb.max(axis=-1)
    mantissa, exponent = np.frexp(peak)
    stored = peak > 1e-32
    scale = np.where(stored, mantissa * 256.0 / np.where(stored, peak, 1.0), 0.0)
    rgbe = np.empty((*rgb.shape[:-1], 4), np.uint8)
    rgbe[..., :3] = (rgb * scale[..., None]).astype(np.uint8)
    rgbe[..., 3] = np.where(stored, exponent + 128, 0)
    return rgbe


def _encode_radiance(rgb: np.ndarray) -> bytes:
    """A Radiance file of non-negative float RGB (H, W, 3), in flat scanlines, which every
    RGBE reader accepts (Ward's normalised pixels never begin with the bytes 2, 2 that would
    mark a run-length scanline)."""
    peak = float(rgb.max(initial=0.0))
    if peak >= 2.0**127:
        raise ValueError(f"image values must be below 2**127 for .hdr (RGBE); got {peak:.6g}")
    height, width = rgb.shape[:2]
    header = b"#?RADIANCE\nFORMAT=%s\n\n-Y %d +X %d\n" % (_RGBE_FORMAT, height, width)
    return header + _float_to_rgbe(rgb.astype(np.float64)).tobytes()


# --------------------------------------------------------------------------------------------
# Reading


@contextlib.contextmanager
def _native_output_captured() -> Iterator[list[str]]:
    """Collect what native code writes to file descriptors 1 and 2 into a list of lines.

    Native decoders (OpenEXR) print their own diagnostics and warnings; brdfkit reports
    a failure as one :class:`ImageReadError` instead, with the first captured line as its reason.
    """
    lines: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    python_streams = _io.StringIO()  # pybind11's py::print writes to sys.stdout, not to fd 1
    with (
        tempfile.TemporaryFile() as capture,
        contextlib.redirect_stdout(python_streams),
        contextlib.redirect_stderr(python_streams),
    ):
        for fd in saved:
            os.dup2(capture.fileno(), fd)
        try:
            yield lines
        finally:
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            capture.seek(0)
            text = capture.read().decode("utf-8", "replace") + python_streams.getvalue()
            lines.extend(line.strip() for line in text.splitlines() if line.strip())


def _first_reason(error: BaseException, captured: list[str]) -> str:
    """A one-line reason: the error's first line, else what the native library printed."""
    text = str(error).strip() or (captured[0] if captured else "")
    return text.splitlines()[0].replace("<python_buffer>: ", "") if text else type(error).__name__


def _read_exr(path: Path, data: bytes) -> np.ndarray:
    import OpenEXR

    captured: list[str] = []
    try:
        with (
            _native_output_captured() as captured,
            OpenEXR.File(_io.BytesIO(data), separate_channels=True) as exr,
        ):
            channels = {name: channel.pixels for name, channel in exr.channels().items()}
    except Exception as error:  # the bindings raise RuntimeError, ValueError, OSError, ...
        reason = _first_reason(error, captured)
        raise ImageReadError(path, f"not a readable OpenEXR image ({reason})") from error
    names = set(channels)
    if {"R", "G", "B"} <= names:
        order = ["R", "G", "B"] + (["A"] if "A" in names else [])
    elif "Y" in names:
        order = ["Y"] + (["A"] if "A" in names else [])
    elif len(names) == 1:
        order = list(names)
    else:
        raise ImageReadError(path, f"expected R, G, B (and A) or Y channels; found {sorted(names)}")
    shapes = {channels[name].shape for name in order}
    if len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise ImageReadError(path, f"channels have different sizes {sorted(shapes)}")
    return np.stack([channels[name] for name in order], axis=-1).astype(np.float32)


def _read_radiance(path: Path, data: bytes) -> np.ndarray:
    width, height, start = _radiance_header(path, data)
    try:
        rgbe = _rgbe_pixels(data, width, height, start)
    except (IndexError, ValueError) as error:
        raise ImageReadError(path, f"truncated or corrupt Radiance pixels ({error})") from None
    return _rgbe_to_float(rgbe)


def _as_opencv_layout(image: Any) -> Any:
    """A Pillow image in the layout OpenCV's ``IMREAD_UNCHANGED`` gave (the readers brdfkit
    used before): a palette expanded to RGB (RGBA with transparency), grey with alpha to RGBA,
    bilevel to 8-bit grey, CMYK and YCbCr to RGB; other modes as stored."""
    if image.mode in ("P", "PA"):
        return image.convert(
            "RGBA" if "transparency" in image.info or image.mode == "PA" else "RGB"
        )
    conversions = {"LA": "RGBA", "La": "RGBA", "1": "L", "CMYK": "RGB", "YCbCr": "RGB"}
    return image.convert(conversions[image.mode]) if image.mode in conversions else image


def _png_bit_depth(data: bytes) -> int:
    """The bit depth a PNG's IHDR chunk declares (8 if there is none to read)."""
    return data[24] if len(data) > 24 and data[12:16] == b"IHDR" else 8


def _tiff_loses_bits_in_pillow(image: Any) -> bool:
    """Pillow reduces colour TIFFs of more than 8 bits a sample to 8 bits (it has no 16-bit
    RGB mode): those are read by tifffile instead."""
    bits = image.tag_v2.get(258, (8,))
    return len(bits) > 1 and max(bits) > 8


def _read_pillow(path: Path, data: bytes) -> np.ndarray:
    """A PNG or TIFF through Pillow; a 16-bit PNG through pypng and a TIFF Pillow would reduce
    (16-bit colour) or cannot read (floating point) through tifffile."""
    import warnings

    from PIL import Image

    is_png = path.suffix.lower() == ".png"
    if is_png and _png_bit_depth(data) == 16:
        return _read_png16(path, data)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(_io.BytesIO(data)) as image:
                if is_png or not _tiff_loses_bits_in_pillow(image):
                    return np.array(_as_opencv_layout(image))
    except Exception as error:  # Pillow raises OSError, SyntaxError, ValueError, ...
        if is_png:
            raise ImageReadError(path, f"not a readable PNG image ({error})") from error
    return _read_tiff(path, data)


def _read_png16(path: Path, data: bytes) -> np.ndarray:
    """A 16-bit PNG through pypng (pure Python; Pillow keeps only 8 bits of colour ones)."""
    import png

    try:
        width, height, rows, info = png.Reader(bytes=data).asDirect()
        codes = np.array([np.asarray(row, np.uint16) for row in rows], np.uint16)
    except (png.Error, ValueError, EOFError) as error:
        raise ImageReadError(path, f"not a readable PNG image ({error})") from error
    codes = codes.reshape(height, width, info["planes"])
    if info["planes"] == 2:  # grey and alpha, as RGBA (OpenCV's layout)
        codes = codes[..., [0, 0, 0, 1]]
    return codes[..., 0] if info["planes"] == 1 else codes


def _read_tiff(path: Path, data: bytes) -> np.ndarray:
    """A TIFF Pillow cannot read without losing bits (16-bit colour, floating point), through
    tifffile: samples as stored, in (height, width, samples) order."""
    import tifffile

    try:
        with tifffile.TiffFile(_io.BytesIO(data)) as tiff:
            page = tiff.pages.first
            image = page.asarray()
            axes = page.axes
    except Exception as error:  # tifffile raises TiffFileError, ValueError, KeyError, ...
        raise ImageReadError(path, f"not a readable TIFF image ({error})") from error
    if axes.startswith("S"):  # planar configuration: one plane a sample
        image = np.moveaxis(image, 0, -1)
    return image


def _read_imageio(path: Path, data: bytes) -> np.ndarray:
    import imageio.v3 as iio

    try:
        return iio.imread(data, plugin="pillow", extension=path.suffix.lower())
    except Exception as error:  # Pillow raises OSError, SyntaxError, ValueError, ...
        raise ImageReadError(path, f"not a readable image ({error})") from error


_READERS: dict[str, Callable[[Path, bytes], np.ndarray]] = {
    ".hdr": _read_radiance,
    ".exr": _read_exr,
    ".png": _read_pillow,
    ".tif": _read_pillow,
    ".tiff": _read_pillow,
    ".jpg": _read_imageio,
    ".jpeg": _read_imageio,
    ".tga": _read_imageio,
    ".bmp": _read_imageio,
}


def _as_float_image(image: np.ndarray, path: Path) -> np.ndarray:
    if image.dtype == np.uint8 or image.dtype == np.uint16:
        image = image.astype(np.float32) / np.iinfo(image.dtype).max
    elif image.dtype.kind == "f":
        image = image.astype(np.float32, copy=not image.flags.writeable)  # a new array once
    else:
        raise ImageReadError(path, f"unsupported sample type {image.dtype}")
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim != 3 or 0 in image.shape:
        raise ImageReadError(path, f"not an image of shape (H, W, C); got {image.shape}")
    return image


def _decode(path: Path) -> np.ndarray:
    """The pixel array a file holds, as its decoder returns it (read into memory first)."""
    suffix = path.suffix.lower()
    if suffix not in _READERS:
        raise FormatError(
            path,
            f"unsupported image extension {suffix!r}; expected one of {', '.join(READ_EXTENSIONS)}",
        )
    if not path.is_file():
        raise ImageNotFoundError(path, "no such file")
    try:
        _affordable(path, "reading it", path.stat().st_size)
        data = path.read_bytes()
    except OSError as error:
        raise ImageReadError(path, f"cannot be read ({error.strerror or error})") from error
    _check_declared_size(path, data)
    return _READERS[suffix](path, data)


def _check_declared_size(path: Path, data: bytes) -> None:
    """Refuse an image whose header declares more than :data:`MAX_IMAGE_PIXELS` pixels, or
    more than the memory available, before anything is decoded. A header that cannot be read
    is left to the decoder, which reports it."""
    declared = _declared_size(path, data)
    if declared is None:
        return
    width, height, channels = declared
    if width * height > MAX_IMAGE_PIXELS:
        raise ImageTooLargeError(
            path,
            f"its header declares {width} × {height} pixels; at most MAX_IMAGE_PIXELS = "
            f"{MAX_IMAGE_PIXELS} are read",
        )
    # the decoder's array (up to 4 bytes a sample) and the float32 image made from it
    nbytes = width * height * channels * 8
    _affordable(path, f"decoding its {width} × {height} × {channels} samples", nbytes)


def _affordable(path: Path, what: str, nbytes: int) -> None:
    try:
        check_memory(what, nbytes)
    except ResourceError as error:
        raise ImageTooLargeError(path, str(error)) from None


def _declared_size(path: Path, data: bytes) -> tuple[int, int, int] | None:
    """(width, height, channels) as the file's header declares them, read without decoding."""
    suffix = path.suffix.lower()
    if suffix == ".exr":
        return _exr_declared_size(data)
    if suffix == ".hdr":
        return _radiance_declared_size(data)
    declared = _pillow_declared_size(path, data)
    if declared is None and suffix in (".tif", ".tiff"):
        return _tiff_declared_size(data)
    return declared


def _tiff_declared_size(data: bytes) -> tuple[int, int, int] | None:
    """A TIFF Pillow cannot open (floating point): its first page's size, from tifffile, which
    reads the tags, not the pixels."""
    import tifffile

    try:
        with tifffile.TiffFile(_io.BytesIO(data)) as tiff:
            page = tiff.pages.first
            return page.imagewidth, page.imagelength, page.samplesperpixel
    except Exception:  # tifffile raises TiffFileError, ValueError, ...: the decoder reports
        return None


def _exr_declared_size(data: bytes) -> tuple[int, int, int] | None:
    import OpenEXR

    try:
        with _native_output_captured():
            header = OpenEXR.File(_io.BytesIO(data), header_only=True).header()
        low, high = header["dataWindow"]
        return int(high[0] - low[0]) + 1, int(high[1] - low[1]) + 1, len(header["channels"])
    except Exception:  # the bindings raise RuntimeError, ValueError, KeyError, ...: see _read_exr
        return None


def _radiance_declared_size(data: bytes) -> tuple[int, int, int] | None:
    """The resolution line that follows a Radiance header's blank line, e.g. ``-Y 512 +X 1024``
    (Ward [2]_)."""
    end = data.find(b"\n\n", 0, 1 << 16)
    if end < 0:
        return None
    fields = data[end + 2 : end + 2 + 64].split(b"\n", 1)[0].split()
    if len(fields) != 4 or not (fields[1].isdigit() and fields[3].isdigit()):
        return None
    first, second = int(fields[1]), int(fields[3])
    rows_first = fields[0].endswith(b"Y")
    return (second, first, 3) if rows_first else (first, second, 3)


def _pillow_declared_size(path: Path, data: bytes) -> tuple[int, int, int] | None:
    """Pillow opens a PNG, TIFF, JPEG, TGA or BMP lazily: its header, not its pixels."""
    import warnings

    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # its notes on odd headers: the decoder reports
            with Image.open(_io.BytesIO(data)) as image:
                width, height = image.size
                return width, height, len(image.getbands())
    except Image.DecompressionBombError:  # Pillow's own limit, above MAX_IMAGE_PIXELS
        raise ImageTooLargeError(
            path,
            f"its header declares more than {2 * Image.MAX_IMAGE_PIXELS} pixels; at most "
            f"MAX_IMAGE_PIXELS = {MAX_IMAGE_PIXELS} are read",
        ) from None
    except Exception:  # Pillow raises OSError, SyntaxError, ValueError, ...: the decoder reports
        return None


def read_image_codes(path: str | os.PathLike) -> np.ndarray:
    """The integer codes an 8- or 16-bit image file stores, shape (H, W, C), RGB(A) order.

    For what needs the codes themselves, such as camera-response recovery from an exposure
    stack. Raises :class:`ImageReadError` (as :func:`read_image` does), also for a file that
    holds floating-point values (``.hdr``, ``.exr``).
    """
    path = Path(path)
    codes = _decode(path)
    if codes.dtype not in (np.uint8, np.uint16):
        raise ImageReadError(path, f"holds {codes.dtype} values, not 8- or 16-bit codes")
    return codes[..., None] if codes.ndim == 2 else codes


def read_image(path: str | os.PathLike, *, srgb_to_linear: bool = False) -> np.ndarray:
    """Read an image file as a float32 array of shape (H, W, C).

    HDR formats (``.hdr``, ``.exr``) give the linear values stored in the file. 8- and 16-bit
    formats (``.png``, ``.tif``, ``.jpg``, ``.tga``, ``.bmp``) give the stored codes divided by
    their maximum, in [0, 1], still sRGB-encoded for ordinary images; with
    ``srgb_to_linear=True`` the colour channels (not alpha) are decoded with
    :func:`srgb_decode`. Greyscale images have ``C = 1``.

    The file is read into memory in Python and decoded from there, so any path that the file
    system accepts (including names that are not valid UTF-8) works, and nothing the native
    decoders print reaches the terminal.

    Parameters
    ----------
    path : str or path-like
        Image file; the format follows the extension (:data:`READ_EXTENSIONS`).
    srgb_to_linear : bool
        Decode 8/16-bit images from sRGB to linear values (HDR formats are linear already and
        are returned unchanged).

    Returns
    -------
    numpy.ndarray (H, W, C), float32

    Raises
    ------
    ImageNotFoundError
        The file does not exist (a ``FormatError`` and a ``FileNotFoundError``).
    ImageReadError
        The file cannot be read, is truncated or corrupt, or its contents are not of the
        expected format (a :class:`~brdfkit.errors.FormatError`, hence a ``ValueError``).
    ValueError
        The extension is not supported.

    References
    ----------
    .. [1] G. Ward, "Real pixels", *Graphics Gems II*, 1991.
    .. [2] IEC 61966-2-1:1999.

    Examples
    --------
    A PNG written from linear middle grey stores sRGB codes; decoding gets the grey back:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = write_image(Path(folder) / "grey.png", np.full((2, 3), 0.18))
    ...     codes, image = read_image_codes(path), read_image(path, srgb_to_linear=True)
    >>> image.shape, image.dtype, int(codes[0, 0, 0]), round(float(image[0, 0, 0]), 3)
    ((2, 3, 1), dtype('float32'), 118, 0.181)
    >>> read_image("missing.png")
    Traceback (most recent call last):
    ...
    brdfkit.io.ImageNotFoundError: missing.png: no such file
    """
    path = Path(path)
    suffix = path.suffix.lower()
    image = _as_float_image(_decode(path), path)
    if srgb_to_linear and suffix not in (".hdr", ".exr"):
        colour = 3 if image.shape[-1] >= 3 else 1
        image[..., :colour] = srgb_decode(image[..., :colour])
    return image


# --------------------------------------------------------------------------------------------
# Writing


def _file_mode() -> int:
    """The mode a new file gets under the process's umask (what ``open(path, "w")`` gives)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def atomic_write(path: str | Path, write_fn: Callable[[Path], None]) -> Path:
    """Write a file atomically: call ``write_fn(tmp)`` on a temporary file beside ``path``, then
    rename it over ``path`` (:func:`os.replace`, atomic on POSIX and Windows).

    The temporary has a plain ASCII name that keeps ``path``'s extension (encoders choose the
    format from it), is removed on every way out if ``write_fn`` fails, and gets the mode the
    umask gives a new file (not ``mkstemp``'s 0600); so ``path`` is either the old file or the
    complete new one. Missing parent folders are created. Returns ``path``. A failure to write
    (a full disk, say) raises :class:`~brdfkit.errors.OutputError` naming ``path``.

    References
    ----------
    .. [1] Python documentation, :func:`os.replace` ("if successful, the renaming will be an
       atomic operation (this is a POSIX requirement)").

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = atomic_write(Path(folder) / "notes.txt", lambda tmp: tmp.write_text("hello"))
    ...     print(path.name, path.read_text(), sorted(p.name for p in path.parent.iterdir()))
    notes.txt hello ['notes.txt']
    """
    path = Path(path)
    suffix = path.suffix if path.suffix.isascii() and path.suffix.isprintable() else ""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix=".brdfkit-", suffix=suffix, dir=path.parent)
    except OSError as error:
        raise OutputError(f"{path} could not be written: {_reason(error)}") from error
    os.close(handle)
    tmp = Path(name)
    try:
        write_fn(tmp)
        os.chmod(tmp, _file_mode())
        os.replace(tmp, path)
    except OSError as error:
        tmp.unlink(missing_ok=True)
        raise output_failure(path, error, tmp) from error
    except BaseException:
        tmp.unlink(missing_ok=True)  # only our temporary: after the rename the name is not ours
        raise
    return path


_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EROFS})
"""The errors of a write that fails for its place: full disk or quota, file too large, a
failing or read-only device."""


def output_failure(path: str | Path, error: OSError, temporary: Path) -> OSError:
    """The error to raise for ``error``, met while ``path`` was written through ``temporary``
    (a file or folder): an :class:`~brdfkit.errors.OutputError` naming ``path`` when the
    failure is the output's, else ``error`` itself (it names its own file: an input the work
    read, say).

    The failure is the output's when it is a failed write (a full disk or quota, a file too
    large, a failing or read-only device), names the temporary or a file inside it (a path the
    user never gave), or names no file at all, such as NumPy's short write on a full disk
    ("32640 requested and 21488 written", with no errno).

    Examples
    --------
    >>> from pathlib import Path
    >>> short = OSError("32640 requested and 21488 written")
    >>> print(output_failure("out/depth.npy", short, Path("out/.brdfkit-x1.npy")))
    out/depth.npy could not be written: 32640 requested and 21488 written
    """
    if isinstance(error, BrdfkitError):
        return error
    named = None if error.filename is None else Path(os.fsdecode(error.filename))
    ours = named is None or named == temporary or temporary in named.parents
    if error.errno not in _WRITE_ERRNOS and not ours:
        return error
    return OutputError(f"{path} could not be written: {_reason(error)}")


def _reason(error: OSError) -> str:
    """What went wrong, without the temporary's name: the system's words for an errno, else
    the message (a short write's counts), else the error's type."""
    return error.strerror or str(error) or type(error).__name__


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (:func:`atomic_write`); returns ``path``."""
    return atomic_write(path, lambda tmp: tmp.write_bytes(data))


def _encode_exr(image: np.ndarray, half: bool) -> bytes:
    import OpenEXR

    names = {1: ["Y"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}[image.shape[-1]]
    pixels = image.astype(np.float16 if half else np.float32)
    channels = {name: np.ascontiguousarray(pixels[..., i]) for i, name in enumerate(names)}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    stream = _io.BytesIO()
    with OpenEXR.File(header, channels) as exr:
        exr.write(stream)
    return stream.getvalue()


def _check_values(path: Path, pixels: np.ndarray, *, nan_allowed: bool) -> None:
    """Refuse, naming ``path``, an image holding infinity, or NaN unless ``nan_allowed``."""
    bad = np.isinf(pixels) if nan_allowed else ~np.isfinite(pixels)
    if bad.any():
        row, column, channel = np.argwhere(bad)[0]
        raise ParameterError(
            f"{path}: the image must be finite; it holds {pixels[row, column, channel]} at pixel "
            f"(row {row}, column {column}, channel {channel}); nothing was written"
        )


def _encode_png(codes: np.ndarray) -> bytes:
    """8-bit codes through Pillow, 16-bit ones through pypng (Pillow writes no 16-bit colour)."""
    stream = _io.BytesIO()
    height, width, channels = codes.shape
    if codes.dtype == np.uint8:
        from PIL import Image

        Image.fromarray(codes[..., 0] if channels == 1 else codes).save(stream, format="PNG")
    else:
        import png

        writer = png.Writer(
            width, height, greyscale=channels == 1, alpha=channels == 4, bitdepth=16
        )
        writer.write_array(stream, codes.reshape(-1))
    return stream.getvalue()


def write_image(
    path: str | os.PathLike,
    image: Array,
    *,
    exposure: float = 0.0,
    bit_depth: int = 8,
    srgb: bool = True,
    half: bool = False,
    nan_marks_missing: bool = False,
) -> Path:
    r"""Write a linear image to ``.exr``, ``.hdr`` or ``.png``, atomically.

    The image is first multiplied by :math:`2^{\text{exposure}}`. Then

    - ``.exr``: stored as float32 (or half floats with ``half=True``), ZIP-compressed; channels
      Y (C = 1), RGB (C = 3) or RGBA (C = 4).
    - ``.hdr``: Radiance RGBE (about 1% relative precision); C = 1 is written as grey RGB,
      C = 3 as RGB. Values must be non-negative.
    - ``.png``: colour channels clipped to [0, 1] and, with ``srgb=True`` (the default),
      sRGB-encoded (:func:`srgb_encode`); ``srgb=False`` stores them as they are (for normal
      maps, masks or data already encoded). Alpha (C = 4) is clipped, never encoded.
      Quantised to ``bit_depth`` 8 or 16 bits by rounding.

    The image is encoded in memory and written from Python (so any file-system path works), to
    a temporary file in the same folder that is renamed to ``path`` only once complete: nothing
    is ever half-written, and the file gets the mode the umask gives.

    Parameters
    ----------
    path : str or path-like
        Destination; the format follows the extension (:data:`WRITE_EXTENSIONS`).
    image : array (H, W) or (H, W, C)
        Linear values, any backend (converted to NumPy here, at the I/O boundary).
    exposure : float
        Scale in stops applied before writing.
    bit_depth : {8, 16}
        PNG sample size.
    srgb : bool
        sRGB-encode PNG colour channels.
    half : bool
        Store EXR channels as 16-bit half floats.
    nan_marks_missing : bool
        ``.exr`` only: NaN marks pixels that have no value (outside a mask) and is written as
        it is. Otherwise, and in every other format, NaN is refused.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    brdfkit.errors.ParameterError
        The image holds NaN (unless ``nan_marks_missing``) or infinity, after ``exposure``
        too, or a value beyond the half-float range with ``half=True``: no file holds a value
        its reader cannot use. The message names ``path``; nothing is written.
    brdfkit.errors.OutputError
        The file could not be written (:func:`atomic_write`).

    References
    ----------
    .. [1] IEC 61966-2-1:1999 (sRGB encoding).
    .. [2] G. Ward, "Real pixels", *Graphics Gems II*, 1991 (RGBE).
    .. [3] F. Kainz, R. Bogart and P. Stanczyk, *Technical Introduction to OpenEXR*, 2013.

    Examples
    --------
    An EXR keeps the linear values (float32 here):

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = write_image(Path(folder) / "red.exr", np.tile([0.5, 0.0, 0.0], (2, 2, 1)))
    ...     pixel = read_image(path)[0, 0]
    >>> pixel.dtype, pixel.tolist()
    (dtype('float32'), [0.5, 0.0, 0.0])

    NaN is refused, naming the file, and nothing is written:

    >>> write_image("broken.exr", np.full((2, 2, 3), np.nan))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: broken.exr: the image must be finite; it holds nan at ...
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in WRITE_EXTENSIONS:
        raise ValueError(
            f"path {str(path)!r} has an unsupported extension {suffix!r} for writing; "
            f"expected one of {', '.join(WRITE_EXTENSIONS)}"
        )
    if bit_depth not in (8, 16):
        raise ValueError(f"bit_depth must be 8 or 16; got {bit_depth!r}")
    if not np.isfinite(exposure):
        raise ValueError(f"exposure must be a finite number of stops; got {exposure!r}")
    pixels = to_numpy(image)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    allowed = {".exr": (1, 3, 4), ".hdr": (1, 3), ".png": (1, 3, 4)}[suffix]
    if pixels.ndim != 3 or pixels.shape[-1] not in allowed or 0 in pixels.shape:
        raise ValueError(
            f"image must have shape (H, W) or (H, W, C) with C in {allowed} for {suffix}; "
            f"got shape {tuple(pixels.shape)}"
        )
    if not np.issubdtype(pixels.dtype, np.number) or np.iscomplexobj(pixels):
        raise ValueError(f"image must hold real numbers; got dtype {pixels.dtype}")
    with np.errstate(over="ignore"):  # an overflow is refused by the check that follows
        pixels = pixels.astype(np.float64) * 2.0**exposure
    _check_values(path, pixels, nan_allowed=nan_marks_missing and suffix == ".exr")
    if suffix == ".exr":
        largest = np.abs(pixels[~np.isnan(pixels)]).max(initial=0.0)
        if half and largest > np.finfo(np.float16).max:
            raise ParameterError(
                f"{path}: the image holds {largest:.6g}, beyond the largest half float "
                f"({np.finfo(np.float16).max:g}); write it without half=True; nothing was written"
            )
        atomic_write_bytes(path, _encode_exr(pixels, half))
        return path

    if suffix == ".hdr":
        if (pixels < 0).any():
            raise ValueError(
                f"image must be non-negative for .hdr (RGBE); got a minimum of {pixels.min():.6g}"
            )
        rgb = np.repeat(pixels, 3, axis=-1) if pixels.shape[-1] == 1 else pixels
        atomic_write_bytes(path, _encode_radiance(rgb.astype(np.float32)))
        return path

    colour = min(pixels.shape[-1], 3)
    encoded = np.clip(pixels, 0.0, 1.0)
    if srgb:
        encoded[..., :colour] = srgb_encode(encoded[..., :colour])
    dtype = np.uint8 if bit_depth == 8 else np.uint16
    codes = np.rint(encoded * np.iinfo(dtype).max).astype(dtype)
    atomic_write_bytes(path, _encode_png(codes))
    return path


# --------------------------------------------------------------------------------------------
# Data folder


def data_path(*parts: str | os.PathLike) -> Path:
    """Path of a file or folder in brdfkit's real-data folder.

    The folder is ``$BRDFKIT_DATA`` when that variable is set; otherwise the first existing
    of ``../shared/data`` relative to the current working directory and ``../shared/data``
    beside the repository that holds this package (for an editable install).

    Parameters
    ----------
    *parts : str or path-like
        Components below the data folder, e.g. ``data_path("envmaps", "probulator",
        "grace.hdr")``.

    Returns
    -------
    pathlib.Path
        An existing path.

    Raises
    ------
    FileNotFoundError
        No data folder was found (the message lists the places tried), or ``parts`` do not
        name an existing file or folder in it.
    """
    environment = os.environ.get("BRDFKIT_DATA")
    if environment:
        candidates = [Path(environment)]
    else:
        repository = Path(__file__).resolve().parents[2]
        candidates = [Path.cwd().parent / "shared" / "data", repository.parent / "shared" / "data"]
    root = next((c for c in candidates if c.is_dir()), None)
    if root is None:
        tried = ", ".join(str(c) for c in candidates)
        source = "BRDFKIT_DATA points to" if environment else "looked in"
        raise FileNotFoundError(
            f"brdfkit data folder not found ({source} {tried}); set BRDFKIT_DATA to the "
            "shared/data folder"
        )
    target = root.joinpath(*parts)
    if not target.exists():
        raise FileNotFoundError(f"{target} does not exist in the brdfkit data folder {root}")
    return target
