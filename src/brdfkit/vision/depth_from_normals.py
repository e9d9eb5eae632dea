"""From a normal-map file to depth and a mesh: what ``brdfkit integrate`` runs.

Input: a normal-map image (or ``.npy``) or a folder in the layout of the bilateral
normal-integration project (Cao et al. 2022): ``normal_map.png``, and optionally ``mask.png``
and ``K.txt``. Its encoding, checked against that project's reader: the 8- or 16-bit RGB
channels are ``n = 2 v / v_max - 1`` with red = x (right), green = y (up), blue = z (towards
the camera), no axis flipped (the frame of :mod:`brdfkit.vision`). ``K.txt`` is the 3 × 3
intrinsics matrix (OpenCV convention: pixels, ``c_x`` a column, ``c_y`` a row); without it
the view is orthographic. Without a mask the object is the pixels that hold a normal
(a vector longer than 1/2: zeros or mid-grey are the background).
The normals are renormalised inside the mask.

Output: depth along the optical axis away from the camera, NaN outside the mask (orthographic:
pixel units, nearest pixel 0; perspective: known up to scale, geometric mean 1 per connected
part of the mask), and a triangle mesh of the masked pixels
(:func:`depth_mesh`).

References
----------
.. [1] X. Cao, H. Santo, B. Shi, F. Okura, Y. Matsushita, "Bilateral normal integration",
   ECCV 2022.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from brdfkit.errors import FormatError, ParameterError
from brdfkit.vision import normal_integration
from brdfkit.vision.bilateral_integration import (
    CONTINUITY,
    PIECES,
    PRIOR_WEIGHT,
    bilateral_integration,
)

if TYPE_CHECKING:
    import trimesh

Progress = Callable[[int, int], None]

DEFAULT_METHOD = "bilateral_pieces"
"""The integrator :func:`integrate_normal_map` uses unless told otherwise: bilateral
integration, which keeps depth discontinuities, with the scale of each piece its weights part
taken from least squares (the lowest mean error on DiLiGenT, ``benchmarks/``)."""

BILATERAL_METHODS = ("bilateral_pieces", "bilateral_continuity", "bilateral")
"""The iterative methods, which report progress."""

PERSPECTIVE_METHODS = (*BILATERAL_METHODS, "least_squares")
"""The methods that take intrinsics ``K``."""


def _bilateral(normals, mask, camera=None, **options: Any) -> np.ndarray:
    return bilateral_integration(normals, mask, camera, **options).depth


def _bilateral_pieces(normals, mask, camera=None, **options: Any) -> np.ndarray:
    return bilateral_integration(normals, mask, camera, pieces=PIECES, **options).depth


def _bilateral_continuity(normals, mask, camera=None, **options: Any) -> np.ndarray:
    return bilateral_integration(normals, mask, camera, continuity=CONTINUITY, **options).depth


METHODS: dict[str, Callable[..., np.ndarray]] = {
    "bilateral_pieces": _bilateral_pieces,
    "bilateral_continuity": _bilateral_continuity,
    "bilateral": _bilateral,
    **normal_integration.METHODS,
}
"""The integrators by name (the ``--method`` choices of ``brdfkit integrate``)."""


def read_intrinsics(path: str | os.PathLike, step: int = 1) -> np.ndarray:
    """The 3×3 camera matrix ``K`` in the text file ``path``, scaled to every ``step``-th pixel
    (its first two rows divided by ``step``).

    Raises
    ------
    brdfkit.errors.FormatError
        The file cannot be read, or does not hold a finite 3×3 matrix with ``K[2, 2] != 0``.
    """
    try:
        matrix = np.loadtxt(path, ndmin=2, encoding="utf-8")
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise FormatError(path, f"not a 3×3 matrix of numbers ({error})") from None
    if matrix.shape != (3, 3) or not np.isfinite(matrix).all() or matrix[2, 2] == 0:
        raise FormatError(path, f"expected a finite 3×3 camera matrix; got shape {matrix.shape}")
    return matrix * np.array([[1 / step], [1 / step], [1]])


def depth_mesh(
    depth: np.ndarray, mask: np.ndarray, camera: np.ndarray | None = None
) -> trimesh.Trimesh:
    """A triangle mesh of a depth map: one vertex per mask pixel, two triangles per 2×2 block of
    mask pixels.

    Vertices are in the camera frame (x right, y up, z towards the camera): orthographic
    ``(u, -v, -z)`` in pixel units; perspective ``z K⁻¹ (u, v, 1)`` with y and z flipped from
    OpenCV's frame. Triangles wind counter-clockwise seen from the camera, so that their normals
    point towards +z.

    Examples
    --------
    >>> import numpy as np
    >>> mesh = depth_mesh(np.zeros((3, 4)), np.ones((3, 4), bool))
    >>> len(mesh.vertices), len(mesh.faces)
    (12, 12)
    >>> bool(np.all(mesh.face_normals[:, 2] > 0))
    True
    """
    import trimesh

    rows, columns = np.nonzero(mask)
    z = depth[mask]
    if camera is None:
        vertices = np.stack([columns, -rows, -z], axis=1).astype(np.float64)
    else:
        rays = np.stack([columns, rows, np.ones_like(columns)], axis=1) @ np.linalg.inv(camera).T
        vertices = rays * z[:, None] * np.array([1.0, -1.0, -1.0])
    index = np.full(mask.shape, -1)
    index[mask] = np.arange(len(z))
    a, b = index[:-1, :-1], index[:-1, 1:]  # top left, top right
    c, d = index[1:, :-1], index[1:, 1:]  # bottom left, bottom right
    full = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    faces = np.concatenate(
        [np.stack([a[full], c[full], b[full]], 1), np.stack([b[full], c[full], d[full]], 1)]
    )
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def check_method(
    method: str, camera: np.ndarray | None = None, name: str = "method", prior: bool = False
) -> None:
    """Refuse an integrator that is not in :data:`METHODS`, one that is orthographic only
    when intrinsics ``camera`` are given, or one that takes no depth prior when ``prior``;
    ``name`` is the argument's, for the message.

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming the argument, its value and the choices.
    """
    if method not in METHODS:
        raise ParameterError(f"{name} must be one of {', '.join(METHODS)}; got {method!r}")
    if camera is not None and method not in PERSPECTIVE_METHODS:
        raise ParameterError(
            f"{name} {method!r} is orthographic only; intrinsics K need one of "
            f"{', '.join(PERSPECTIVE_METHODS)}"
        )
    if prior and method not in BILATERAL_METHODS:
        raise ParameterError(
            f"a depth prior needs {name} one of {', '.join(BILATERAL_METHODS)}; got {method!r}"
        )


@dataclass(frozen=True)
class NormalMap:
    """A normal map ready to integrate.

    Attributes
    ----------
    normals : (H, W, 3) normals inside the mask (x right, y up, z towards the camera), zero
        outside; as the file stores them, not renormalised: the integrators take each
        normal's direction, and its length at most weights its equations (by ``1 ± 1e-4`` in a
        16-bit map); bilateral integration, whose inexact solves carry such changes far, then
        follows the authors' code exactly (DiLiGenT bear 0.33398 mm of mean
        absolute depth error as theirs; 0.33392 from the renormalised normals).
    mask : (H, W) bool.
    camera : (3, 3) intrinsics ``K``, or None (orthographic).
    name : the file or folder it was read from.
    """

    normals: np.ndarray
    mask: np.ndarray
    camera: np.ndarray | None
    name: str


def _read_camera(path: Path) -> np.ndarray:
    """``K`` from a text file, refused with the file's name unless a finite 3 × 3 matrix with
    positive focal lengths."""
    camera = read_intrinsics(path)
    try:
        return normal_integration.check_camera(camera)
    except ParameterError as error:
        raise FormatError(path, str(error).replace("camera ", "", 1)) from None


def read_normal_map_input(
    normals: str | os.PathLike,
    mask: str | os.PathLike | None = None,
    camera: str | os.PathLike | None = None,
) -> NormalMap:
    """Read a normal map, its mask and its intrinsics.

    Parameters
    ----------
    normals : a normal-map image or ``.npy``, or a folder holding ``normal_map.png`` (and
        maybe ``mask.png``, ``K.txt``, used unless ``mask`` or ``camera`` is given).
    mask : a mask image (white = object); when omitted and the folder has none, the pixels that
        hold a normal (a vector longer than ½).
    camera : a text file of the 3 × 3 intrinsics ``K``; orthographic when omitted and the
        folder has none.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file: missing or unreadable, a mask of another size or empty, a zero normal
        inside the mask, no pixel holding a normal (without a mask), or ``K`` not a finite
        3 × 3 matrix with positive focal lengths.
    """
    from brdfkit._array import HOLDS_NORMAL, holds_normal
    from brdfkit.vision.datasets import read_mask, read_normal_map

    source = Path(normals)
    if source.is_dir():
        folder, source = source, source / "normal_map.png"
        mask = (
            mask if mask is not None or not (folder / "mask.png").is_file() else folder / "mask.png"
        )
        camera = (
            camera if camera is not None or not (folder / "K.txt").is_file() else folder / "K.txt"
        )
    values = read_normal_map(source)
    if mask is None:
        pixels = holds_normal(values)
        if not pixels.any():
            longer = f"a vector longer than {HOLDS_NORMAL}"
            raise FormatError(source, f"no pixel holds a normal ({longer}); give a mask")
    else:
        pixels = read_mask(mask)
        if pixels.shape != values.shape[:2]:
            raise FormatError(
                mask, f"the mask is {pixels.shape}, the normal map {values.shape[:2]}"
            )
        if not pixels.any():
            raise FormatError(mask, "the mask has no pixels set")
    if np.any(np.linalg.norm(values[pixels], axis=-1) < 1e-6):
        raise FormatError(source, "a normal inside the mask is zero (no direction)")
    stored = np.where(pixels[..., None], values, 0.0)
    intrinsics = None if camera is None else _read_camera(Path(camera))
    return NormalMap(stored, pixels, intrinsics, str(normals))


@dataclass(frozen=True)
class IntegratedSurface:
    """The depth of a :class:`NormalMap` and how it was found.

    Attributes
    ----------
    depth : (H, W) depth along the optical axis away from the camera, NaN outside the mask.
    mask : (H, W) bool.
    camera : (3, 3) intrinsics ``K`` or None (orthographic).
    method : the integrator's name (a key of :data:`METHODS`).
    prior_depths : the depths a prior gave inside the mask (0: no prior; with one, ``depth`` is
        in the prior's units).
    """

    depth: np.ndarray
    mask: np.ndarray
    camera: np.ndarray | None
    method: str
    prior_depths: int = 0

    @property
    def mesh(self) -> trimesh.Trimesh:
        """One vertex per mask pixel, two triangles per 2 × 2 block of mask pixels."""
        return depth_mesh(self.depth, self.mask, self.camera)

    def summary(self) -> dict[str, Any]:
        """What ``brdfkit integrate --json`` reports: method, projection, pixels, depth range."""
        inside = self.depth[self.mask]
        return {
            "method": self.method,
            "projection": "orthographic" if self.camera is None else "perspective",
            "pixels": int(self.mask.sum()),
            "height": int(self.mask.shape[0]),
            "width": int(self.mask.shape[1]),
            "depth_min": float(inside.min()),
            "depth_max": float(inside.max()),
            "prior_depths": self.prior_depths,
        }


def integrate_normal_map(
    data: NormalMap,
    method: str = DEFAULT_METHOD,
    *,
    depth_prior: np.ndarray | None = None,
    prior_weight: float = PRIOR_WEIGHT,
    callback: Progress | None = None,
) -> IntegratedSurface:
    """Integrate ``data`` into depth with ``method`` (a key of :data:`METHODS`).

    ``depth_prior`` (H, W), depth known in places and NaN elsewhere, goes to the bilateral
    methods with ``prior_weight``
    (:func:`~brdfkit.vision.bilateral_integration.bilateral_integration`); with it
    ``bilateral_pieces`` leaves the scale of each piece holding a known depth to the prior
    (the others take least squares' moved onto it). ``callback(done, total)`` reports the
    iterations of the bilateral methods.

    Raises
    ------
    brdfkit.errors.ParameterError
        An unknown method, intrinsics with a method that is orthographic only, or a prior with
        a method that takes none (or one it refuses).

    Examples
    --------
    A plane whose depth grows by half a pixel per column, integrated by the default method:

    >>> import numpy as np
    >>> normals = np.broadcast_to(np.array([0.5, 0.0, 1.0]) / np.sqrt(1.25), (3, 4, 3))
    >>> data = NormalMap(normals, np.ones((3, 4), bool), None, "plane")
    >>> integrate_normal_map(data).depth.round(6).tolist()
    [[0.0, 0.5, 1.0, 1.5], [0.0, 0.5, 1.0, 1.5], [0.0, 0.5, 1.0, 1.5]]
    """
    check_method(method, data.camera, prior=depth_prior is not None)
    arguments: dict[str, Any] = {} if data.camera is None else {"camera": data.camera}
    if method in BILATERAL_METHODS:
        arguments["callback"] = callback
    known = 0
    if depth_prior is not None:
        arguments.update(depth_prior=depth_prior, prior_weight=prior_weight)
        known = int(np.sum(np.isfinite(depth_prior) & data.mask))
    depth = METHODS[method](data.normals, data.mask, **arguments)
    return IntegratedSurface(depth, data.mask, data.camera, method, known)


def integrate_normal_file(
    normals: str | os.PathLike,
    mask: str | os.PathLike | None = None,
    camera: str | os.PathLike | None = None,
    method: str = DEFAULT_METHOD,
    *,
    prior: str | os.PathLike | None = None,
    prior_weight: float = PRIOR_WEIGHT,
    callback: Progress | None = None,
) -> IntegratedSurface:
    """:func:`read_normal_map_input` (and :func:`read_depth_prior`) then
    :func:`integrate_normal_map`: the pipeline of ``brdfkit integrate``.

    Raises
    ------
    brdfkit.errors.FormatError
        A file that cannot be read, or a prior that does not fit the normal map (named).
    brdfkit.errors.ParameterError
        An unknown method, intrinsics with a method that is orthographic only, or a prior with
        a method that takes none.
    """
    check_method(method, prior=prior is not None)
    data = read_normal_map_input(normals, mask, camera)
    depth_prior = None if prior is None else read_depth_prior(prior, data)
    return integrate_normal_map(
        data, method, depth_prior=depth_prior, prior_weight=prior_weight, callback=callback
    )


def read_depth_prior(path: str | os.PathLike, data: NormalMap) -> np.ndarray:
    """The depth map ``path`` (:func:`~brdfkit.vision.datasets.read_depth_map`) as a prior for
    ``data``: NaN or infinity where unknown; in perspective, in any unit (the result's), else
    in pixels.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file: unreadable, of another size than the normal map, without a known
        depth inside the mask, or (perspective) a depth that is not positive.
    """
    from brdfkit.vision.datasets import read_depth_map

    prior = read_depth_map(path)
    if prior.shape != data.mask.shape:
        raise FormatError(path, f"the prior is {prior.shape}, the normal map {data.mask.shape}")
    known = prior[data.mask & np.isfinite(prior)]
    if known.size == 0:
        raise FormatError(path, "no depth is known inside the mask (all NaN or infinite there)")
    if data.camera is not None and known.min() <= 0:
        raise FormatError(path, f"perspective depth must be positive; found {known.min():g}")
    return prior
