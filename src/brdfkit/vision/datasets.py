"""Photometric-stereo and normal-integration data sets: readers, a writer and a synthesiser.

Frame and units (every loader returns these): light directions and normals are unit vectors in
the camera frame **x right, y up, z towards the camera** (the DiLiGenT convention); images are
linear floats, ``(N, H, W, C)`` float32, already divided by the per-light, per-channel light
intensities when the data set gives them. Image rows go down, so a direction's y is minus the
row direction.

Layouts
-------
DiLiGenT (Shi et al. 2016/2019), one object per folder::

    filenames.txt          001.png ... 096.png (16-bit RGB PNG, names relative to the folder)
    light_directions.txt   N rows "x y z"
    light_intensities.txt  N rows "r g b"
    mask.png               8-bit, object > 0
    Normal_gt.mat          variable ``Normal_gt`` (H, W, 3), optional

The classic course set "psm" (``photometric_stereo/psm``): ``psm/<obj>/<obj>.<k>.tga`` images,
``psm/<obj>.txt`` listing the count, the images and last the mask (paths start with a
``psmImages/`` folder that this copy does not have), and ``psm/lights.txt`` (count, then
``x y z`` rows in the frame above; a student's approximate calibration from the chrome sphere).
Its two spheres, ``chrome`` and ``gray``, get ground-truth normals from the circle fitted to
their mask.

Normal maps (``normal_map.png`` of the DiLiGenT normal-integration packaging) are 16-bit RGB
PNGs encoding ``n = 2 v / 65535 - 1`` per channel in the same frame; this was checked against
``depth_gt``: the normals of the back-projected ground-truth depth agree with the decoded map to
0.7° mean on bear (0.8° cat, 0.9° goblet) with x right / y up / z towards the camera, and are
off by 45° or more under any other sign convention.

References
----------
.. [1] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019.
.. [2] X. Cao, H. Santo, B. Shi, F. Okura, Y. Matsushita, "Bilateral normal integration",
   ECCV 2022 (the normal-integration packaging of DiLiGenT).
.. [3] J. F. Blinn, "Models of light reflection for computer synthesized pictures", SIGGRAPH 1977.
"""

from __future__ import annotations

import os
import tokenize
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from brdfkit import io
from brdfkit._array import check_param, normalize
from brdfkit._checks import as_float_array, check_count, check_image_shape, check_memory
from brdfkit.errors import FormatError, OutputError, ParameterError
from brdfkit.vision.calibration import LINEAR_SUFFIXES
from brdfkit.vision.normal_integration import check_camera
from brdfkit.vision.photometric_stereo import MAX_PIXELS, fit_circle, sphere_normals

MAX_STEP = 4096
"""Largest ``step`` (subsampling) the loaders accept."""

MAX_GRID = 1000
"""Most lights per row or column of :func:`diligent_like_lights`."""

PSM_SPHERES = ("chrome", "gray")
"""psm objects that are spheres: their ground-truth normals follow from the mask's circle."""

Callback = Callable[[int, int], None]
"""Progress callback ``callback(done, total)`` called after each image is read."""


@dataclass(frozen=True)
class PhotometricStereoData:
    """A photometric-stereo data set in memory.

    Attributes
    ----------
    images : (N, H, W, C) float32 linear images, divided by the light intensities.
    light_directions : (N, 3) unit directions towards the lights (x right, y up, z to camera).
    mask : (H, W) bool object mask.
    normals : (H, W, 3) ground-truth unit normals, or ``None``.
    light_intensities : (N, C) intensities the images were divided by, or ``None``.
    name : a label (the folder or object name).
    """

    images: np.ndarray
    light_directions: np.ndarray
    mask: np.ndarray
    normals: np.ndarray | None = None
    light_intensities: np.ndarray | None = None
    name: str = ""

    def __post_init__(self) -> None:
        """Check the shapes agree.

        Raises
        ------
        brdfkit.errors.ParameterError
            Naming the array whose shape disagrees, or an empty mask.
        """
        if self.images.ndim != 4:
            raise ParameterError(f"images must have shape (N, H, W, C), got {self.images.shape}")
        n_lights, height, width, channels = self.images.shape
        if n_lights < 3:
            raise ParameterError(f"photometric stereo needs at least 3 images, got {n_lights}")
        if self.light_directions.shape != (n_lights, 3):
            raise ParameterError(
                f"light_directions must have shape ({n_lights}, 3) to match the images, got "
                f"{self.light_directions.shape}"
            )
        if self.mask.shape != (height, width):
            raise ParameterError(f"mask must have shape {(height, width)}, got {self.mask.shape}")
        if not self.mask.any():
            raise ParameterError(f"mask of {self.name!r} has no pixels set")
        if self.normals is not None and self.normals.shape != (height, width, 3):
            raise ParameterError(
                f"normals must have shape {(height, width, 3)}, got {self.normals.shape}"
            )
        if self.light_intensities is not None and self.light_intensities.shape != (
            n_lights,
            channels,
        ):
            raise ParameterError(
                f"light_intensities must have shape {(n_lights, channels)}, got "
                f"{self.light_intensities.shape}"
            )


def read_image(path: str | Path) -> np.ndarray:
    """Read an image as float32 ``(H, W, C)`` without its alpha channel.

    :func:`brdfkit.io.read_image` (16-bit PNGs kept at 16 bits, integer codes divided by their
    type's maximum, so in [0, 1]), then any alpha channel dropped.

    Raises
    ------
    brdfkit.io.ImageReadError
        The file is missing or cannot be decoded.
    brdfkit.errors.FormatError
        It holds NaN or infinity (a float format).
    """
    return io.without_alpha(_read_finite(path))


def _read_finite(path: str | Path) -> np.ndarray:
    """:func:`brdfkit.io.read_image`, refusing NaN and infinity (a float format)."""
    image = io.read_image(path)
    if not np.all(np.isfinite(image)):
        raise FormatError(path, "the image holds NaN or infinity")
    return image


def read_mask(path: str | Path) -> np.ndarray:
    """Read a mask image as bool ``(H, W)``: pixels whose brightest channel exceeds half the
    image's brightest value, so that masks stored as 0 and 255, 0 and 1 or 0 and 65535 read
    alike (an all-black mask has no pixel set). An alpha channel that varies is the mask (a
    cut-out); an opaque one is ignored.

    Raises
    ------
    brdfkit.errors.FormatError
        As :func:`read_image`.
    """
    image = _read_finite(path)
    if image.shape[2] in (2, 4):
        alpha = image[..., -1:]
        image = alpha if alpha.min() < alpha.max() else io.without_alpha(image)
    brightest = image.max(axis=2)
    return brightest > 0.5 * brightest.max()


def read_normal_map(path: str | os.PathLike) -> np.ndarray:
    """Read a normal map: a ``.npy`` array or an image, as float64 ``(H, W, 3)``.

    ``.npy`` files hold the normals themselves (any real dtype; read without unpickling). Images
    are read with :func:`brdfkit.io.read_image_codes`: integer formats (PNG, TGA, TIFF, …, 8
    or 16 bits) encode ``n = 2 v / v_max - 1`` per channel (as :func:`write_normal_map` writes
    them), decoded here from the codes in float64, exact to the last bit (no float32 step);
    the float formats of :data:`brdfkit.vision.calibration.LINEAR_SUFFIXES` (``.exr``) hold
    the normals as they are. The normals are returned as stored, not renormalised.

    Parameters
    ----------
    path : the ``.npy`` or image file.

    Returns
    -------
    numpy.ndarray (H, W, 3) float64, finite.

    Raises
    ------
    brdfkit.errors.FormatError
        The file is missing, truncated, pickled, not numeric, not of shape (H, W, 3) or holds
        NaN or infinity (:class:`brdfkit.io.ImageReadError` for an image that cannot be decoded,
        or that holds floating-point values in a format other than ``.exr`` and ``.hdr``).
    """
    path = Path(path)
    if path.suffix.lower() == ".npy":
        normals = _read_npy(path)
    elif path.suffix.lower() in LINEAR_SUFFIXES:
        normals = read_image(path).astype(np.float64)
    else:
        codes = io.without_alpha(io.read_image_codes(path))
        normals = 2.0 * codes / np.iinfo(codes.dtype).max - 1.0
    if normals.ndim != 3 or normals.shape[2] != 3 or 0 in normals.shape:
        raise FormatError(path, f"a normal map must have shape (H, W, 3); got {normals.shape}")
    if not np.all(np.isfinite(normals)):
        raise FormatError(path, "the normal map holds NaN or infinity")
    return normals


def read_depth_map(path: str | os.PathLike) -> np.ndarray:
    """Read a depth map: a ``.npy`` array or a float image (``.exr``, ``.hdr``), as ``(H, W)``,
    NaN or infinity where the depth is unknown (as ``brdfkit integrate`` writes
    ``depth.npy`` and ``depth.exr``).

    Raises
    ------
    brdfkit.errors.FormatError
        The file is missing, truncated, pickled or not numeric, not of shape (H, W) (an image:
        not one channel), or an integer image (whose codes carry no depth unit).
    """
    path = Path(path)
    if path.suffix.lower() == ".npy":
        depth = _read_npy(path)
    elif path.suffix.lower() in LINEAR_SUFFIXES:
        depth = io.read_image(path).astype(np.float64)  # NaN kept: unknown depth
    else:
        raise FormatError(path, "a depth map must be .npy or a float image (.exr, .hdr)")
    if depth.ndim == 3 and depth.shape[2] == 1:
        depth = depth[..., 0]
    if depth.ndim != 2 or 0 in depth.shape:
        raise FormatError(path, f"a depth map must have shape (H, W); got {depth.shape}")
    return depth


def _read_npy(path: Path) -> np.ndarray:
    """A real-valued ``.npy`` array as float64, read memory-mapped (a header claiming more
    than the file holds is refused before anything is allocated) and never unpickled."""
    if not path.is_file():
        raise FormatError(path, "no such file")
    # numpy's header parser (ast and tokenize) raises SyntaxError and TokenError on a garbled
    # header; ValueError on bad magic, pickles or a size beyond the file; OverflowError on a
    # shape whose byte count overflows.
    errors = (ValueError, OSError, EOFError, SyntaxError, tokenize.TokenError, OverflowError)
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except errors as error:
        raise FormatError(path, f"not a readable .npy array ({error})") from error
    if not isinstance(array, np.ndarray):
        raise FormatError(path, "not a .npy array (an .npz archive?)")
    if array.dtype.kind not in "biuf":
        raise FormatError(path, f"must hold real numbers; got dtype {array.dtype}")
    check_memory(f"reading {path}", 8 * array.size)
    return np.array(array, dtype=np.float64)


def write_normal_map(path: str | Path, normals: ArrayLike) -> None:
    """Encode unit normals ``(H, W, 3)`` as a 16-bit RGB PNG, ``v = round(65535 (n + 1) / 2)``.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``normals`` is not a finite (H, W, 3) array.
    brdfkit.errors.OutputError
        ``path`` cannot be written.
    """
    from brdfkit.io import write_image

    normals = as_float_array("normals", normals)
    if normals.ndim != 3 or normals.shape[2] != 3:
        raise ParameterError(f"normals must have shape (H, W, 3), got {normals.shape}")
    # write_image quantises as round(65535 clip(v, 0, 1)), encoded in memory (any path works).
    _written(path, lambda: write_image(path, (normals + 1) / 2, bit_depth=16, srgb=False))


def _written(path: str | Path, write: Callable[[], object]) -> None:
    """Run ``write`` and turn a failure of the file system into an OutputError naming ``path``."""
    try:
        write()
    except OSError as error:
        raise OutputError(f"cannot write {str(path)!r}: {error.strerror or error}") from error


def _read_text(path: Path) -> str:
    """The UTF-8 text of ``path``.

    Raises
    ------
    brdfkit.errors.FormatError
        The file is missing, unreadable or not UTF-8.
    """
    if not path.is_file():
        raise FormatError(path, "no such file")
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as error:
        raise FormatError(path, "not UTF-8 text", offset=error.start) from error
    except OSError as error:
        raise FormatError(path, f"cannot be read ({error.strerror})") from error


def _lines(path: Path) -> list[tuple[int, list[str]]]:
    """``(line number, tokens)`` of the non-blank lines of a text file, ``#`` comments cut."""
    rows = []
    for number, line in enumerate(_read_text(path).splitlines(), start=1):
        tokens = line.split("#", 1)[0].split()
        if tokens:
            rows.append((number, tokens))
    return rows


def _parse_int(path: Path, token: str, number: int) -> int:
    """An integer token of a text file (``number`` its line)."""
    try:
        return int(token)
    except ValueError:
        raise FormatError(path, f"expected an integer count; got {token!r}", offset=number,
                          line=True) from None  # fmt: skip


def _read_rows(path: Path, columns: int, *, counted: bool = False) -> np.ndarray:
    """A text table of ``columns`` finite floats per line; ``counted``: after a first line
    holding the number of rows.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file and the line: missing, not UTF-8, a non-number, NaN or infinity, a
        wrong number of columns, no rows, or rows that disagree with the count.
    """
    lines = _lines(path)
    if counted:
        if not lines or len(lines[0][1]) != 1:
            raise FormatError(path, "the first line must hold the number of rows", offset=1,
                              line=True)  # fmt: skip
        expected = _parse_int(path, lines[0][1][0], lines[0][0])
        lines = lines[1:]
        if expected != len(lines):
            raise FormatError(path, f"the first line says {expected} rows; {len(lines)} follow")
    if not lines:
        raise FormatError(path, "no rows")
    table = np.empty((len(lines), columns))
    for k, (number, tokens) in enumerate(lines):
        if len(tokens) != columns:
            raise FormatError(path, f"expected {columns} numbers; got {len(tokens)}",
                              offset=number, line=True)  # fmt: skip
        try:
            table[k] = [float(token) for token in tokens]
        except ValueError:
            raise FormatError(path, f"not a number in {' '.join(tokens)!r:.80}", offset=number,
                              line=True) from None  # fmt: skip
        if not np.all(np.isfinite(table[k])):
            raise FormatError(path, "NaN or infinity", offset=number, line=True)
    return table


def _read_lights(path: Path, listing: Path, count: int, *, counted: bool = False) -> np.ndarray:
    """``count`` unit light directions (normalised here) from a text file of ``x y z`` rows,
    for the ``count`` images of ``listing``.

    Raises
    ------
    brdfkit.errors.FormatError
        As :func:`_read_rows`, a row count other than ``count``, or a zero row.
    """
    lights = _read_rows(path, 3, counted=counted)
    if len(lights) != count:
        raise FormatError(
            path, f"{path.name} has {len(lights)} rows but {listing.name} lists {count} images"
        )
    lights, length = _row_lengths(lights)
    if np.any(length == 0):
        row = int(np.flatnonzero(length[:, 0] == 0)[0])
        raise FormatError(path, f"light direction {row + 1} is zero")
    return lights / length


def _row_lengths(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Finite ``rows`` (N, 3) and their lengths (N, 1); a row whose squared length over- or
    underflows (components near 1e±154 and beyond) is first divided by its largest component,
    so that only a zero row has length 0."""
    with np.errstate(over="ignore", under="ignore"):  # detected and handled below
        length = np.linalg.norm(rows, axis=1, keepdims=True)
    largest = np.abs(rows).max(axis=1, keepdims=True)
    extreme = np.isinf(length) | ((length == 0) & (largest > 0))
    if np.any(extreme):
        rows = np.where(extreme, rows / np.where(largest > 0, largest, 1.0), rows)
        length = np.linalg.norm(rows, axis=1, keepdims=True)
    return rows, length


def _unit_rows(lights: np.ndarray, source: str) -> np.ndarray:
    """Finite rows normalised to unit length; zero rows or another shape are a ParameterError."""
    if lights.ndim != 2 or lights.shape[1] != 3:
        raise ParameterError(f"light directions from {source} must be (N, 3); got {lights.shape}")
    lights, length = _row_lengths(lights)
    if not np.all(np.isfinite(length)) or np.any(length == 0):
        raise ParameterError(f"light directions from {source} must be (N, 3), finite and non-zero")
    return lights / length


def _stack(
    paths: list[Path], step: int, callback: Callback | None
) -> tuple[np.ndarray, tuple[int, int]]:
    """Images as one ``(N, H, W, C)`` float32 array, every ``step``-th pixel, and the full
    ``(H, W)`` of the files.

    Raises
    ------
    brdfkit.errors.FormatError
        An image that cannot be read or whose size or channels differ from the first.
    brdfkit.errors.ResourceError
        The stack would not fit in memory.
    """
    full = read_image(paths[0])
    first = full[::step, ::step]
    check_memory(f"reading {len(paths)} images of {full.shape}", len(paths) * 4 * first.size)
    stack = np.empty((len(paths), *first.shape), dtype=np.float32)
    stack[0] = first
    for k, path in enumerate(paths[1:], start=1):
        image = read_image(path)
        if image.shape != full.shape:
            raise FormatError(
                path, f"has shape {image.shape}, expected {full.shape} like {str(paths[0])!r}"
            )
        stack[k] = image[::step, ::step]
        if callback is not None:
            callback(k + 1, len(paths))
    return stack, full.shape[:2]


def _read_mask_of(path: Path, shape: tuple[int, int]) -> np.ndarray:
    """The mask of images of ``shape`` (full resolution), with at least one pixel set."""
    mask = read_mask(path)
    if mask.shape != shape:
        raise FormatError(path, f"the mask is {mask.shape}, the images are {shape}")
    if not mask.any():
        raise FormatError(path, "the mask has no pixels set")
    return mask


_MAT_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 9: "f8", 12: "i8",
              13: "u8"}  # fmt: skip
"""MAT-file level 5 data types of numeric data (miINT8 … miUINT64) as NumPy type codes."""

_MAT_NUMERIC_CLASSES = range(6, 16)
"""mxDOUBLE_CLASS … mxUINT64_CLASS."""

MAX_MAT_BYTES = 2**31
"""Largest decompressed variable :func:`load_diligent` reads from a ``.mat`` file."""


def _mat_elements(path: Path, data: bytes, order: str, base: int | None = None):
    """``(type, payload)`` of the consecutive level-5 data elements in ``data``, which starts
    at byte ``base`` of the file (``None``: inside a compressed element, offsets unknown)."""
    position = 0
    while position < len(data):
        where = None if base is None else base + position
        if len(data) - position < 8:
            raise FormatError(path, "truncated data element tag", offset=where)
        kind, size = (int(v) for v in np.frombuffer(data, f"{order}u4", 2, position))
        if kind >> 16:  # small data element: size in the upper half, data in the tag
            kind, size, start, end = kind & 0xFFFF, kind >> 16, position + 4, position + 8
            if size > 4:
                raise FormatError(path, "small data element longer than 4 bytes", offset=where)
        else:
            start = position + 8
            end = start + (size if kind == 15 else -(-size // 8) * 8)
        if start + size > len(data):
            raise FormatError(path, "data element runs past the end", offset=where)
        yield kind, data[start : start + size]
        position = end


def _mat_matrix(path: Path, payload: bytes, order: str) -> tuple[str, np.ndarray | None]:
    """The name and, for a real numeric class, the array of a miMATRIX element (its dimensions
    miINT32, as the format says, or miUINT32, as some writers store them)."""
    parts = list(_mat_elements(path, payload, order))
    if len(parts) < 3 or parts[0][0] != 6 or len(parts[0][1]) != 8 or parts[1][0] not in (5, 6):
        raise FormatError(path, "malformed miMATRIX element (flags, dimensions)")
    flags = int(np.frombuffer(parts[0][1], f"{order}u4", 1)[0])
    name = parts[2][1].decode("latin-1")
    if flags & 0xFF not in _MAT_NUMERIC_CLASSES:
        return name, None
    shape = tuple(int(n) for n in np.frombuffer(parts[1][1], f"{order}{_MAT_TYPES[parts[1][0]]}"))
    if len(parts) < 4 or len(shape) < 2 or min(shape) < 0 or parts[3][0] not in _MAT_TYPES:
        raise FormatError(path, "malformed numeric array", field=name)
    if flags & 0x800:
        raise FormatError(path, "complex arrays are not supported", field=name)
    dtype = np.dtype(f"{order}{_MAT_TYPES[parts[3][0]]}")
    if len(parts[3][1]) != dtype.itemsize * int(np.prod(shape, dtype=object)):
        raise FormatError(path, f"data size does not match the dimensions {shape}", field=name)
    values = np.frombuffer(parts[3][1], dtype)
    return name, values.reshape(shape, order="F").astype(np.float64)


def _read_mat_array(path: Path, key: str) -> np.ndarray:
    """The real numeric variable ``key`` of a MATLAB level-5 ``.mat`` file, as float64.

    Read here rather than with ``scipy.io.loadmat``: SciPy's compiled reader crashes the
    interpreter (a segmentation fault) on some corrupt files, which no ``except`` can turn
    into an error. Level 5 (MATLAB 5 to 7.2, the format of ``scipy.io.savemat`` and of
    DiLiGenT) with compressed or plain elements in either byte order; v4 and v7.3 (HDF5) files
    are refused.
    """
    data = path.read_bytes()
    if len(data) < 128 or data[126:128] not in (b"IM", b"MI"):
        raise FormatError(path, "not a MATLAB level-5 .mat file (no header)")
    order = "<" if data[126:128] == b"IM" else ">"
    for kind, payload in _mat_elements(path, data[128:], order, base=128):
        if kind == 15:
            inflater = zlib.decompressobj()
            try:
                payload = inflater.decompress(payload, MAX_MAT_BYTES)
            except zlib.error as error:
                raise FormatError(path, f"corrupt compressed element ({error})") from error
            if inflater.unconsumed_tail:
                raise FormatError(path, f"a variable exceeds MAX_MAT_BYTES = {MAX_MAT_BYTES}")
            elements = list(_mat_elements(path, payload, order))
            if len(elements) != 1:
                raise FormatError(path, "a compressed element must hold one variable")
            kind, payload = elements[0]
        if kind != 14:
            continue
        name, array = _mat_matrix(path, payload, order)
        if name == key:
            if array is None:
                raise FormatError(path, "must be a real numeric array", field=key)
            return array
    raise FormatError(path, f"has no variable {key!r}", field=key)


def _read_normal_gt(path: Path, mask: np.ndarray) -> np.ndarray:
    """``Normal_gt`` of a DiLiGenT ``.mat`` file, ``(H, W, 3)`` like ``mask``; finite inside the
    mask (NaN or infinity outside it, which no method reads, become 0)."""
    normals = _read_mat_array(path, "Normal_gt")
    if normals.shape != (*mask.shape, 3):
        raise FormatError(
            path,
            f"must be (H, W, 3) = {(*mask.shape, 3)} normals; got {normals.shape}",
            field="Normal_gt",
        )
    finite = np.isfinite(normals)
    if not np.all(finite[mask]):
        raise FormatError(path, "normals inside the mask hold NaN or infinity", field="Normal_gt")
    return np.where(finite, normals, 0.0)


def read_normal_gt(path: str | Path, mask: ArrayLike) -> np.ndarray:
    """The ground-truth normals ``(H, W, 3)`` of a DiLiGenT ``Normal_gt.mat``, for a ``mask``
    ``(H, W)``: finite inside the mask (NaN or infinity outside it become 0).

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file: not MATLAB level 5, no ``Normal_gt``, the wrong shape, or NaN or
        infinity inside the mask.
    """
    return _read_normal_gt(Path(path), np.asarray(mask, dtype=bool))


def image_names(folder: str | Path) -> list[str]:
    """The image file names that a DiLiGenT folder's ``filenames.txt`` lists, in order.

    Raises
    ------
    brdfkit.errors.FormatError
        The listing is missing or is not UTF-8 text.
    """
    return [token for _, tokens in _lines(Path(folder) / "filenames.txt") for token in tokens]


def _read_intensities(path: Path, count: int) -> np.ndarray:
    """``(count, 3)`` positive light intensities from ``r g b`` rows."""
    intensities = _read_rows(path, 3)
    if len(intensities) != count:
        raise FormatError(path, f"has {len(intensities)} rows; {count} images are listed")
    if np.any(intensities <= 0):
        row = int(np.flatnonzero(np.any(intensities <= 0, axis=1))[0])
        raise FormatError(path, "intensities must be positive", offset=row + 1, line=True)
    return intensities


def _divide(images: np.ndarray, intensities: np.ndarray, path: Path) -> None:
    """Divide each float32 image by its light's intensities, in place (in float64, one image at
    a time); intensities so small that an image leaves the float32 range are an error."""
    limit = np.finfo(np.float32).max
    for k, (image, intensity) in enumerate(zip(images, intensities, strict=True)):
        with np.errstate(over="ignore"):  # detected just below
            scaled = image / intensity
        if not np.all(np.abs(scaled) <= limit):
            raise FormatError(path, "intensity too small: the image overflows float32",
                              offset=k + 1, line=True)  # fmt: skip
        images[k] = scaled


def _check_step(step: int) -> int:
    return check_count("step", step, MAX_STEP)


def load_diligent(
    folder: str | Path, *, step: int = 1, callback: Callback | None = None
) -> PhotometricStereoData:
    """Load one object in the DiLiGenT layout (see the module docstring).

    Images are divided by ``light_intensities.txt`` per light and channel; ``Normal_gt.mat`` is
    read when present (MATLAB level 5, see :func:`_read_mat_array`). ``step`` keeps every
    ``step``-th row and column.

    Parameters
    ----------
    folder : the object's folder.
    step : subsampling, 1 … :data:`MAX_STEP`.
    callback : progress, ``callback(done, total)`` after each image.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file (and line): a missing or unreadable file, counts that disagree, NaN,
        infinity or non-numbers in the text files, images of different sizes, a mask of the
        wrong size or empty, a ``Normal_gt.mat`` without ``Normal_gt`` or of the wrong shape.
    brdfkit.errors.ParameterError, brdfkit.errors.ResourceError
        A bad ``step``; images that would not fit in memory.

    References
    ----------
    B. Shi et al., IEEE TPAMI 41(2), 2019.
    """
    step = _check_step(step)
    folder = Path(folder)
    listing = folder / "filenames.txt"
    if not listing.is_file():
        raise FormatError(folder, "not a DiLiGenT folder: no filenames.txt")
    names = [token for _, tokens in _lines(listing) for token in tokens]
    if len(names) < 3:
        raise FormatError(listing, f"photometric stereo needs at least 3 images; {names} listed")
    lights = _read_lights(folder / "light_directions.txt", listing, len(names))
    intensity_file = folder / "light_intensities.txt"
    intensities = None
    if intensity_file.is_file():
        intensities = _read_intensities(intensity_file, len(names))
    images, shape = _stack([folder / name for name in names], step, callback)
    if intensities is not None:
        if images.shape[3] == 1:
            intensities = intensities.mean(axis=1, keepdims=True)
        _divide(images, intensities, intensity_file)
    full_mask = _read_mask_of(folder / "mask.png", shape)
    mask = full_mask[::step, ::step]
    if not mask.any():
        raise FormatError(folder / "mask.png", f"no mask pixel is left at step {step}")
    normals = None
    if (folder / "Normal_gt.mat").is_file():
        normals = _read_normal_gt(folder / "Normal_gt.mat", full_mask)[::step, ::step]
    return PhotometricStereoData(
        images=images,
        light_directions=lights,
        mask=mask,
        normals=normals,
        light_intensities=intensities,
        name=folder.name.removesuffix("PNG"),
    )


def _read_psm_listing(listing: Path) -> tuple[list[str], str]:
    """The image entries and the mask entry of a psm ``<obj>.txt`` listing."""
    lines = _lines(listing)
    if not lines:
        raise FormatError(listing, "empty: expected a count, the images and the mask")
    number, tokens = lines[0]
    count = _parse_int(listing, tokens[0], number)
    entries = [token for _, tokens in lines for token in tokens][1:]
    if count < 3 or len(entries) != count + 1:
        raise FormatError(
            listing,
            f"must list a count >= 3, that many images and the mask; got the count {count} and "
            f"{len(entries)} entries",
        )
    return entries[:-1], entries[-1]


def load_psm(
    folder: str | Path,
    *,
    light_directions: ArrayLike | None = None,
    step: int = 1,
    callback: Callback | None = None,
) -> PhotometricStereoData:
    """Load one object of the classic "psm" course set, e.g. ``.../psm/gray``.

    The listing ``<folder>/../<obj>.txt`` gives the images and the mask; the lights are
    ``light_directions`` when given (e.g. from
    :func:`~brdfkit.vision.photometric_stereo.calibrate_lights_chrome_sphere`), otherwise
    ``<folder>/../lights.txt``. The spheres in :data:`PSM_SPHERES` get ground-truth normals from
    the circle fitted to their mask (:func:`~brdfkit.vision.photometric_stereo.fit_circle`).

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file (and line): the listing, ``lights.txt``, an image or the mask missing,
        unreadable or inconsistent (counts, sizes, NaN, non-numbers, a zero direction).
    brdfkit.errors.ParameterError
        ``light_directions`` not a finite, non-zero (N, 3) array; a bad ``step``.
    brdfkit.errors.ResourceError
        ``step`` above :data:`MAX_STEP`, or images that would not fit in memory.
    """
    step = _check_step(step)
    folder = Path(folder)
    listing = folder.parent / f"{folder.name}.txt"
    if not listing.is_file():
        raise FormatError(folder, f"not a psm object folder: no {listing.name} beside it")
    image_entries, mask_entry = _read_psm_listing(listing)
    count = len(image_entries)
    if light_directions is None:
        lights = _read_lights(folder.parent / "lights.txt", listing, count, counted=True)
    else:
        lights = _unit_rows(as_float_array("light_directions", light_directions),
                            "light_directions")  # fmt: skip
        if lights.shape != (count, 3):
            raise ParameterError(f"light_directions must have shape ({count}, 3), got "
                                 f"{lights.shape}")  # fmt: skip

    def resolve(entry: str) -> Path:
        # Listed paths start with a "psmImages/" folder that this copy of the set does not have.
        direct = folder.parent / entry
        return direct if direct.exists() else folder.parent.joinpath(*Path(entry).parts[1:])

    images, shape = _stack([resolve(entry) for entry in image_entries], step, callback)
    full_mask = _read_mask_of(resolve(mask_entry), shape)
    mask = full_mask[::step, ::step]
    if not mask.any():
        raise FormatError(resolve(mask_entry), f"no mask pixel is left at step {step}")
    normals = None
    if folder.name in PSM_SPHERES:  # fitted at full resolution, then subsampled like the mask
        c_x, c_y, radius = fit_circle(full_mask)
        normals = sphere_normals(full_mask.shape, (c_x, c_y), radius)[0][::step, ::step]
    return PhotometricStereoData(
        images=images, light_directions=lights, mask=mask, normals=normals, name=folder.name
    )


def load_dataset(
    path: str | Path, *, step: int = 1, callback: Callback | None = None
) -> PhotometricStereoData:
    """Load a DiLiGenT folder (has ``filenames.txt``) or a psm object folder (``<obj>.txt``
    beside it), whichever ``path`` is.

    Raises
    ------
    brdfkit.errors.FormatError
        ``path`` does not exist or is neither layout, or as :func:`load_diligent` and
        :func:`load_psm`.
    """
    path = Path(path)
    if not path.is_dir():
        raise FormatError(path, "data set folder does not exist")
    if (path / "filenames.txt").is_file():
        return load_diligent(path, step=step, callback=callback)
    if (path.parent / f"{path.name}.txt").is_file():
        return load_psm(path, step=step, callback=callback)
    raise FormatError(
        path,
        f"neither a DiLiGenT folder (filenames.txt) nor a psm object folder ({path.name}.txt "
        "beside it)",
    )


def save_diligent(data: PhotometricStereoData, folder: str | Path) -> None:
    """Write ``data`` in the DiLiGenT layout (16-bit PNGs; :func:`load_diligent` reads it back).

    Images are multiplied back by ``data.light_intensities`` (when set) and quantised to 16 bits,
    values above 1 clipping; the mask is 8-bit, the normals go to ``Normal_gt.mat``.

    Raises
    ------
    brdfkit.errors.OutputError
        An image cannot be written.
    """
    import scipy.io

    from brdfkit.io import write_image

    folder = Path(folder)
    _written(folder, lambda: folder.mkdir(parents=True, exist_ok=True))
    raw = data.images.astype(np.float64)
    intensities = data.light_intensities
    if intensities is not None:
        raw = raw * intensities[:, None, None, :]
        intensities = np.broadcast_to(intensities, (len(raw), 3))  # the layout's "r g b" rows
    names = [f"{k + 1:03d}.png" for k in range(len(raw))]
    for name, image in zip(names, raw, strict=True):
        path = folder / name
        _written(path, lambda: write_image(path, image, bit_depth=16, srgb=False))  # noqa: B023
    (folder / "filenames.txt").write_text("\n".join(names) + "\n")
    np.savetxt(folder / "light_directions.txt", data.light_directions, fmt="%.8f")
    if intensities is not None:
        np.savetxt(folder / "light_intensities.txt", intensities, fmt="%.8f")
    mask = data.mask.astype(np.float32)
    _written(folder / "mask.png", lambda: write_image(folder / "mask.png", mask, srgb=False))
    if data.normals is not None:
        scipy.io.savemat(folder / "Normal_gt.mat", {"Normal_gt": data.normals})


@dataclass(frozen=True)
class NormalIntegrationData:
    """One object of the DiLiGenT normal-integration packaging.

    Attributes
    ----------
    normals : (H, W, 3) unit normals (x right, y up, z towards the camera).
    mask : (H, W) bool.
    depth : (H, W) ground-truth depth along the optical axis (NaN outside the mask).
    camera : (3, 3) perspective intrinsics ``K`` (pixels).
    name : the object name.
    """

    normals: np.ndarray
    mask: np.ndarray
    depth: np.ndarray
    camera: np.ndarray
    name: str


def _read_npz_array(path: Path, key: str) -> np.ndarray:
    """Array ``key`` of an ``.npz`` archive (never unpickled), as float64."""
    if not path.is_file():
        raise FormatError(path, "no such file")
    try:
        with np.load(path, allow_pickle=False) as archive:
            if key not in archive.files:
                raise FormatError(path, f"has no array {key!r}", field=key)
            array = archive[key]
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as error:
        raise FormatError(path, f"not a readable .npz archive ({error})") from error
    except AttributeError as error:  # np.load returned an ndarray: an .npy, not an archive
        raise FormatError(path, "not an .npz archive") from error
    if array.dtype.kind not in "biuf":
        raise FormatError(path, f"must hold real numbers; got dtype {array.dtype}", field=key)
    return array.astype(np.float64)


def load_normal_integration(folder: str | Path) -> NormalIntegrationData:
    """Load ``normal_map.png``, ``mask.png``, ``depth_gt.npz`` and ``K.txt`` from ``folder``.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file: missing or unreadable, shapes that disagree, depth not finite inside
        the mask, or ``K.txt`` not a finite 3 × 3 matrix.

    References
    ----------
    X. Cao et al., "Bilateral normal integration", ECCV 2022; B. Shi et al., TPAMI 2019.
    """
    folder = Path(folder)
    normals = read_normal_map(folder / "normal_map.png")
    mask = _read_mask_of(folder / "mask.png", normals.shape[:2])
    depth_file = folder / "depth_gt.npz"
    depth = _read_npz_array(depth_file, "depth_gt")
    if depth.shape != mask.shape:
        raise FormatError(depth_file, f"depth is {depth.shape}, the normal map {mask.shape}",
                          field="depth_gt")  # fmt: skip
    if not np.all(np.isfinite(depth[mask])):
        raise FormatError(depth_file, "depth inside the mask holds NaN or infinity",
                          field="depth_gt")  # fmt: skip
    camera = _read_rows(folder / "K.txt", 3)
    if camera.shape != (3, 3):
        raise FormatError(folder / "K.txt", f"K must be 3 × 3; got {camera.shape}")
    normals = np.where(mask[..., None], normalize(normals), 0.0)
    return NormalIntegrationData(normals, mask, depth, camera, folder.name)


# ----------------------------------------------------------------------------------------------
# Synthetic data on given normals


def diligent_like_lights(
    n_columns: int = 12, n_rows: int = 8, max_polar_angle: float = np.radians(45.0)
) -> np.ndarray:
    """Directions of a planar ``n_rows x n_columns`` grid of lights facing the object.

    Like DiLiGenT's 8 x 12 LED array: lights evenly spaced on the plane ``z = 1`` in front of
    the object, the corner ones at ``max_polar_angle`` (radians) from the view axis.

    Returns
    -------
    (n_rows * n_columns, 3) unit directions, row by row from the top left.

    Raises
    ------
    brdfkit.errors.ParameterError
        Fewer than 3 lights, or ``max_polar_angle`` outside (0, π/2).
    brdfkit.errors.ResourceError
        ``n_columns`` or ``n_rows`` above :data:`MAX_GRID`.
    """
    check_count("n_columns", n_columns, MAX_GRID)
    check_count("n_rows", n_rows, MAX_GRID)
    if n_columns * n_rows < 3:
        raise ParameterError(f"need at least 3 lights, got a {n_rows} x {n_columns} grid")
    if not 0 < max_polar_angle < np.pi / 2:
        raise ParameterError(f"max_polar_angle must be in (0, pi/2), got {max_polar_angle}")
    x = np.arange(n_columns) - (n_columns - 1) / 2
    y = (n_rows - 1) / 2 - np.arange(n_rows)
    spacing = np.tan(max_polar_angle) / max(np.hypot(x[0], y[0]), 1e-12)
    gx, gy = np.meshgrid(x * spacing, y * spacing)
    lights = np.stack([gx.ravel(), gy.ravel(), np.ones(gx.size)], axis=1)
    return lights / np.linalg.norm(lights, axis=1, keepdims=True)


def perspective_sphere(
    shape: tuple[int, int], camera: ArrayLike, centre: ArrayLike, radius: float
) -> NormalIntegrationData:
    r"""Exact normals and depth of a sphere seen through a pinhole camera: a ground truth for
    perspective normal integration whose silhouette grazes.

    Pixel ``(u, v)`` (column, row) looks along :math:`d = ((u - c_x) / f_x, (c_y - v) / f_y,
    -1)` (x right, y up, z towards the camera); its depth is the nearest root ``t`` of
    :math:`|t\,d - c| = r`, and its normal :math:`(t\,d - c) / r`.

    Parameters
    ----------
    shape : (H, W) of the image.
    camera : (3, 3) intrinsics ``K``.
    centre : (3,) the sphere's centre in the camera frame, in front of it (``z < -radius``).
    radius : > 0, in the units of ``centre`` (those of the depth).

    Returns
    -------
    NormalIntegrationData
        The pixels whose ray meets the sphere as the mask; depth along the optical axis (NaN
        outside); ``name`` ``"sphere"``.

    Raises
    ------
    brdfkit.errors.ParameterError
        A bad ``shape``, ``camera`` (see
        :func:`~brdfkit.vision.normal_integration.check_camera`), a centre that is not three
        finite numbers, a radius that is not finite and positive, or a sphere not wholly in
        front of the camera.
    brdfkit.errors.ResourceError
        More than :data:`~brdfkit.vision.photometric_stereo.MAX_PIXELS` pixels, or more than
        the memory available holds.

    References
    ----------
    R. Hartley, A. Zisserman, *Multiple View Geometry in Computer Vision*, 2nd ed., Cambridge
    University Press 2004, §6.1 (the pinhole camera).

    Examples
    --------
    A ball of 5 mm radius 100 mm away, 40 pixels in radius; its nearest point 95 mm away, and
    every pixel's point on the sphere (a unit normal):

    >>> import numpy as np
    >>> camera = np.array([[800.0, 0, 47.5], [0, 800.0, 47.5], [0, 0, 1]])
    >>> ball = perspective_sphere((96, 96), camera, centre=(0.0, 0.0, -100.0), radius=5.0)
    >>> int(ball.mask.sum()), float(np.nanmin(ball.depth).round(2))
    (5040, 95.0)
    >>> bool(np.allclose(np.linalg.norm(ball.normals[ball.mask], axis=1), 1.0))
    True
    """
    height, width = check_image_shape(shape, MAX_PIXELS)
    camera = check_camera(camera)
    centre = as_float_array("centre", centre)
    if centre.shape != (3,):
        raise ParameterError(f"centre must be three numbers (x, y, z), got shape {centre.shape}")
    check_param("radius", radius, 0.0, lo_open=True)
    if not centre[2] + radius < 0:
        raise ParameterError(
            f"the sphere must lie in front of the camera (centre z + radius < 0), got centre "
            f"z {centre[2]} and radius {radius}"
        )
    check_memory(f"a sphere of {height} x {width} pixels", 80 * height * width)
    rows, columns = np.indices((height, width), dtype=np.float64)
    rays = np.stack(
        [(columns - camera[0, 2]) / camera[0, 0], (camera[1, 2] - rows) / camera[1, 1],
         -np.ones((height, width))], axis=-1,
    )  # fmt: skip
    half_b, a = rays @ centre, np.sum(rays**2, axis=-1)
    discriminant = half_b**2 - a * (centre @ centre - radius**2)
    mask = discriminant > 0
    depth = np.where(mask, (half_b - np.sqrt(np.where(mask, discriminant, 0.0))) / a, np.nan)
    normals = (depth[..., None] * rays - centre) / radius
    normals = np.where(mask[..., None], normals, 0.0)
    return NormalIntegrationData(normals, mask, depth, camera, "sphere")


def horizon_excess(
    height: ArrayLike, light_directions: ArrayLike, pixel_size: float = 1.0
) -> np.ndarray:
    """How far the height field rises above each surface pixel's ray to each distant light.

    Marching from a pixel ``p`` towards the light across the image one pixel at a time, the
    excess is ``max_t h(q_t) - h(p) - |q_t - p| s tan(elevation)`` over the pixels ``q_t``
    nearest ``p + t d``, ``t = 1, 2, ...``, with ``d`` the light's image-plane direction (rows
    go down: ``d = (l_x, -l_y) / |..|``), ``|q_t - p|`` the distance to that pixel (a diagonal
    step is longer than 1) and ``s = pixel_size``: the light reaches ``p`` past occluders of
    heights known to within ``b`` exactly when the excess is at most ``b`` (Max's horizon map,
    one march for every bias). ``-inf`` where no surface lies along the ray, and for
    lights at the zenith or below the horizon. Marched by a compiled kernel, pixel by pixel and
    the lights over the cores, each march stopping where nothing further along can change its
    maximum (:mod:`brdfkit.vision._horizon_kernels`; the same numbers as the NumPy march of
    :func:`horizon_excess_reference`).

    Parameters
    ----------
    height : (H, W) height towards the camera, in the units of ``pixel_size``; NaN where there
        is no surface (never occludes).
    light_directions : (N, 3) directions towards the lights.
    pixel_size : footprint of a pixel on the surface (orthographic approximation).

    Returns
    -------
    (N, P) excess at the ``P`` surface pixels (the finite heights, in row-major order:
    ``height[np.isfinite(height)]``'s).

    Raises
    ------
    brdfkit.errors.ParameterError
        Wrong shapes, non-finite light directions, a ``pixel_size`` that is not positive, or
        no finite height.

    References
    ----------
    N. L. Max, "Horizon mapping: shadows for bump-mapped surfaces", The Visual Computer 4(2),
    1988.
    """
    height = as_float_array("height", height, finite=False)
    lights = as_float_array("light_directions", light_directions)
    if height.ndim != 2 or lights.ndim != 2 or lights.shape[1] != 3:
        raise ParameterError(
            f"height must be (H, W) and light_directions (N, 3), got "
            f"{height.shape} and {lights.shape}"
        )
    if not pixel_size > 0:
        raise ParameterError(f"pixel_size must be positive, got {pixel_size}")
    surface = np.isfinite(height)
    if not surface.any():
        raise ParameterError("height has no finite value")
    from brdfkit.vision._horizon_kernels import horizon_excess_box

    box, rows, columns, h = _surface_box(height, surface)
    excess = np.empty((len(lights), len(h)))
    horizon_excess_box(box, rows, columns, h, lights, float(pixel_size), excess)
    return excess


def _surface_box(
    height: np.ndarray, surface: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The heights in the surface's bounding box (``-inf`` off the surface: no occluder lies
    outside it), the surface pixels' rows and columns in the box and their heights."""
    rows, columns = np.nonzero(surface)
    top, left = rows.min(), columns.min()
    box = np.where(surface, height, -np.inf)[top : rows.max() + 1, left : columns.max() + 1]
    rows, columns = rows - top, columns - left
    return box, rows, columns, box[rows, columns]


def horizon_excess_reference(
    height: np.ndarray, light_directions: np.ndarray, pixel_size: float = 1.0
) -> np.ndarray:
    """:func:`horizon_excess` as its formula reads, in NumPy: every pixel of the surface marched
    at once, one step at a time, to the step count the tallest possible occluder needs. The
    readable version of the compiled march (:mod:`brdfkit.vision._horizon_kernels`), which the
    tests hold equal to it; no checks (``height`` with a finite value, ``(N, 3)`` lights)."""
    lights = np.asarray(light_directions, dtype=np.float64)
    box, rows, columns, h = _surface_box(height, np.isfinite(height))
    span = h.max() - h.min()
    excess = np.full((len(lights), len(h)), -np.inf)
    for k, (l_x, l_y, l_z) in enumerate(lights):
        planar = np.hypot(l_x, l_y)
        if planar < 1e-12 or l_z <= 0:
            continue
        rise = pixel_size * l_z / planar
        d_col, d_row = l_x / planar, -l_y / planar
        for t in range(1, int(min(span / rise, sum(box.shape))) + 3):
            r = np.rint(rows + t * d_row).astype(np.intp)
            c = np.rint(columns + t * d_col).astype(np.intp)
            inside = (r >= 0) & (r < box.shape[0]) & (c >= 0) & (c < box.shape[1])
            occluder = np.where(
                inside, box[r.clip(0, box.shape[0] - 1), c.clip(0, box.shape[1] - 1)], -np.inf
            )
            distance = np.hypot(r - rows, c - columns)
            np.maximum(excess[k], occluder - h - distance * rise, out=excess[k])
    return excess


def cast_shadows(
    height: ArrayLike, light_directions: ArrayLike, pixel_size: float = 1.0, *, bias: float = 0.0
) -> np.ndarray:
    """Which pixels of a height field each distant light reaches (cast shadows only).

    A pixel ``p`` is shadowed when, marching from it towards the light, the height field rises
    above the ray by more than ``b = bias``: :func:`horizon_excess` ``> b`` (0: exact heights;
    > 0 the shadow-mapping bias of a height field known only so well, e.g. one integrated from
    measured normals).

    Parameters
    ----------
    height : (H, W) height towards the camera, in the units of ``pixel_size``; NaN where there
        is no surface (never occludes, and is lit).
    light_directions : (N, 3) directions towards the lights.
    pixel_size : footprint of a pixel on the surface (orthographic approximation).
    bias : height an occluder must rise above the ray to block it, >= 0 (units of ``height``;
        infinity: nothing is shadowed).

    Returns
    -------
    (N, H, W) bool, True where the light is not blocked (everywhere off the surface).

    Raises
    ------
    brdfkit.errors.ParameterError
        As :func:`horizon_excess` and :func:`lit_within`.

    References
    ----------
    N. L. Max, "Horizon mapping: shadows for bump-mapped surfaces", The Visual Computer 4(2),
    1988.
    """
    excess = horizon_excess(height, light_directions, pixel_size)
    return lit_within(excess, np.isfinite(np.asarray(height, dtype=np.float64)), bias)


def lit_within(excess: np.ndarray, surface: np.ndarray, bias: float) -> np.ndarray:
    """The lights' visibility ``(N, H, W)`` where occluders are known to within ``bias``: True
    where :func:`horizon_excess`'s ``excess`` ``(N, P)`` is at most ``bias``, and everywhere
    off ``surface`` ``(H, W)`` (its ``P`` pixels in row-major order). One march of
    :func:`horizon_excess` serves every bias.

    Raises
    ------
    brdfkit.errors.ParameterError
        A negative ``bias``.
    """
    if not bias >= 0:
        raise ParameterError(f"bias must be >= 0, got {bias}")
    lit = np.ones((len(excess), *surface.shape), dtype=bool)
    lit[:, surface] = excess <= bias
    return lit


def render_synthetic(
    normals: ArrayLike,
    mask: ArrayLike,
    light_directions: ArrayLike,
    *,
    albedo: ArrayLike = 0.6,
    specular: float = 0.0,
    shininess: float = 50.0,
    lit: ArrayLike | None = None,
    light_intensities: ArrayLike | None = None,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
    name: str = "synthetic",
) -> PhotometricStereoData:
    """Images of given normals under distant lights: Lambertian plus a Blinn–Phong lobe.

    ``I_k = (rho + k_s max(0, n . h_k)^s) max(0, n . l_k) V_k + noise``, with ``h_k`` the unit
    half vector of ``l_k`` and the view ``(0, 0, 1)``, ``V_k`` the cast-shadow visibility
    (``lit``, e.g. from :func:`cast_shadows`) and Gaussian noise of standard deviation
    ``noise``; negative values clip to 0. The specular lobe is white (dichromatic model). The
    images are stored divided by ``light_intensities`` (as the loaders return them), which are
    kept so that :func:`save_diligent` writes the raw, unequal-intensity images.

    Parameters
    ----------
    normals : (H, W, 3) unit normals.
    mask : (H, W) bool; images are 0 outside.
    light_directions : (N, 3) directions towards the lights.
    albedo : diffuse albedo, broadcast to (H, W, C): a scalar, (C,) or (H, W, C).
    specular, shininess : Blinn–Phong ``k_s`` and exponent ``s``.
    lit : (N, H, W) bool cast-shadow visibility; everything lit when omitted.
    light_intensities : (N, C) per-light intensities to record; ones when omitted.

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, or NaN, infinity or negative values in the arguments.

    References
    ----------
    J. F. Blinn, "Models of light reflection for computer synthesized pictures", SIGGRAPH 1977;
    R. J. Woodham, Optical Engineering 19(1), 1980.
    """
    normals = as_float_array("normals", normals)
    mask = np.asarray(mask, dtype=bool)
    lights = _unit_rows(as_float_array("light_directions", light_directions), "light_directions")
    for name, value in (("specular", specular), ("shininess", shininess), ("noise", noise)):
        check_param(name, value, 0.0)
    if normals.ndim != 3 or normals.shape[2] != 3 or mask.shape != normals.shape[:2]:
        raise ParameterError(
            f"normals must be (H, W, 3) and mask (H, W), got {normals.shape} and {mask.shape}"
        )
    albedo = np.atleast_1d(as_float_array("albedo", albedo))
    albedo = np.broadcast_to(albedo, (*mask.shape, albedo.shape[-1]))
    half = lights + np.array([0.0, 0.0, 1.0])
    half /= np.linalg.norm(half, axis=1, keepdims=True)
    cos_theta_i = np.clip(np.einsum("hwj,nj->nhw", normals, lights), 0, None)
    cos_theta_h = np.clip(np.einsum("hwj,nj->nhw", normals, half), 0, None)
    if lit is not None:
        cos_theta_i = cos_theta_i * np.asarray(lit, dtype=bool)
    images = (albedo[None] + specular * cos_theta_h[..., None] ** shininess) * cos_theta_i[
        ..., None
    ]
    if noise > 0:
        rng = np.random.default_rng() if rng is None else rng
        images = np.clip(images + rng.normal(0.0, noise, images.shape), 0, None)
    images *= mask[None, :, :, None]
    channels = images.shape[3]
    if light_intensities is not None:
        light_intensities = np.asarray(light_intensities, dtype=np.float64)
    return PhotometricStereoData(
        images=images.astype(np.float32),
        light_directions=lights,
        mask=mask,
        normals=np.where(mask[..., None], normals, 0.0),
        light_intensities=light_intensities
        if light_intensities is not None
        else np.ones((len(lights), channels)),
        name=name,
    )
