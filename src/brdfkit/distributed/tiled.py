"""Out-of-core photometric stereo: the image stack in a Zarr store, solved tile by tile.

A DiLiGenT folder is first *staged*: each image is decoded once (one task per image, one image
in a worker's memory), divided by its light's intensities and written into a Zarr array
``(N, H, W, C)`` float32 chunked ``(1, t, t, C)``. The stack is then read lazily as a
:mod:`dask.array` of ``(N, t, t, C)`` blocks (each block the ``N`` chunks of one tile), a
per-pixel method runs on each block, and the normals ``(H, W, 3)`` and albedo ``(H, W, C)`` go
to Zarr arrays tile by tile. A worker holds one tile's observations at a time, so the stack
may be far larger than the memory of any worker.

Per-pixel methods give the same normals tile by tile as on the whole image (least squares,
trimmed least squares). Sparse regression stops on a residual summed over the pixels it is
given, so per tile its iterations stop at their own tolerance: results agree to that
tolerance, not to rounding. Methods that couple pixels (robust PCA's low rank) are refused.

The depth comes from :func:`integrate`: least-squares integration on overlapping tiles, whose
constants are then chosen by least squares so that the tiles agree on their overlaps.

References
----------
.. [1] R. J. Woodham, "Photometric method for determining surface orientation from multiple
   images", Optical Engineering 19(1), 1980.
.. [2] Zarr specification v3 (https://zarr-specs.readthedocs.io): chunked N-dimensional arrays.
.. [3] Y. Quéau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", J. Math. Imaging
   Vis. 60, 2018 (the least-squares functional each tile minimises).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from brdfkit.errors import FormatError, ParameterError, require_extra

PER_PIXEL = ("least_squares", "trimmed", "sparse_regression")
"""The methods of :data:`brdfkit.vision.photometric_stereo.METHODS` that run tile by tile."""

DEFAULT_TILE = 512
"""Tile side (pixels) when none is given."""

OVERLAP = 16
"""Pixels by which the integration tiles overlap each neighbour."""


@dataclass(frozen=True)
class Stack:
    """A staged data set: the Zarr stack and what the solve needs beside it.

    Attributes
    ----------
    path : the Zarr array ``(N, H, W, C)`` float32 of images divided by the intensities.
    light_directions : (N, 3) unit directions. mask : (H, W) bool. tile : the chunk side.
    name : the data set's name. normals_file : ``Normal_gt.mat`` or ``None``.
    """

    path: str
    light_directions: np.ndarray
    mask: np.ndarray
    tile: int
    name: str
    normals_file: str | None

    shape: tuple[int, int, int, int]

    @property
    def nbytes(self) -> int:
        return 4 * int(np.prod(self.shape))


def _stage_image(path: str, scale: np.ndarray | None, store: str, k: int, shape: tuple) -> int:
    """Decode image ``k``, divide it by ``scale`` and write it into the Zarr stack (a task)."""
    zarr = require_extra("zarr")

    from brdfkit.vision.datasets import read_image

    image = read_image(path)
    if image.shape != shape:
        raise FormatError(path, f"has shape {image.shape}, expected {shape} like the first image")
    if scale is not None:
        image = (image / scale).astype(np.float32)
    zarr.open_array(store, mode="r+")[k] = image
    return k


def stage(folder: str | Path, store: str | Path, tile: int = DEFAULT_TILE) -> Stack:
    """Write the images of the DiLiGenT ``folder`` into a Zarr stack at ``store`` (one Dask task
    per image, on the current client or Dask's default scheduler).

    Raises
    ------
    brdfkit.errors.FormatError
        As :func:`brdfkit.vision.datasets.load_diligent` (missing files, counts that disagree,
        images of different sizes, a bad mask).
    brdfkit.errors.ParameterError
        A tile side below 16.
    """
    import dask

    zarr = require_extra("zarr")

    from brdfkit.vision import datasets

    if not isinstance(tile, int) or tile < 16:
        raise ParameterError(f"--chunks must be an integer of at least 16 pixels; got {tile!r}")
    folder = Path(folder)
    listing = folder / "filenames.txt"
    if not listing.is_file():
        raise FormatError(folder, "not a DiLiGenT folder: no filenames.txt")
    names = [token for _, tokens in datasets._lines(listing) for token in tokens]
    if len(names) < 3:
        raise FormatError(listing, f"photometric stereo needs at least 3 images; {names} listed")
    lights = datasets._read_lights(folder / "light_directions.txt", listing, len(names))
    first = datasets.read_image(folder / names[0])
    intensities = None
    if (folder / "light_intensities.txt").is_file():
        intensities = datasets._read_intensities(folder / "light_intensities.txt", len(names))
        if first.shape[2] == 1:
            intensities = intensities.mean(axis=1, keepdims=True)
    mask = datasets._read_mask_of(folder / "mask.png", first.shape[:2])
    shape = tuple(first.shape)
    del first
    zarr.open_array(str(store), mode="w", shape=(len(names), *shape),
                    chunks=(1, tile, tile, shape[2]), dtype="float32")  # fmt: skip
    jobs = [
        dask.delayed(_stage_image, pure=False)(
            str(folder / name),
            None if intensities is None else intensities[k],
            str(store),
            k,
            shape,
        )
        for k, name in enumerate(names)
    ]
    dask.compute(*jobs)
    normals = folder / "Normal_gt.mat"
    return Stack(str(store), lights, mask, tile, folder.name.removesuffix("PNG"),
                 str(normals) if normals.is_file() else None, (len(names), *shape))  # fmt: skip


def _solve_tile(block: np.ndarray, mask: np.ndarray, lights: np.ndarray, method: str) -> np.ndarray:
    """Normals and albedo ``(t, t, 3 + C)`` of one ``(N, t, t, C)`` block and its ``(1, t, t, 1)``
    mask (zeros off the mask)."""
    from brdfkit.vision.photometric_stereo import METHODS

    mask = mask[0, :, :, 0]
    out = np.zeros((*mask.shape, 3 + block.shape[3]), dtype=np.float32)
    if mask.any():
        result = METHODS[method](block, lights, mask)
        out[..., :3] = result.normals
        out[..., 3:] = result.albedo
    return out


def solve(stack: Stack, method: str, normals_store: str | Path, albedo_store: str | Path) -> None:
    """Run ``method`` on every tile of ``stack``; write the normals ``(H, W, 3)`` and albedo
    ``(H, W, C)`` float32 to Zarr arrays (tile by tile, on the current client).

    Raises
    ------
    brdfkit.errors.ParameterError
        A method not in :data:`PER_PIXEL`.
    """
    import dask
    import dask.array as da

    if method not in PER_PIXEL:
        raise ParameterError(
            f"--method {method!r} couples pixels and cannot run tile by tile; "
            f"out of core use one of {', '.join(PER_PIXEL)}"
        )
    n, _, _, channels = stack.shape
    t = stack.tile
    images = da.from_zarr(stack.path, chunks=(n, t, t, channels))
    mask = da.from_array(stack.mask, chunks=(t, t))
    maps = da.map_blocks(
        _solve_tile, images, mask[None, :, :, None], stack.light_directions, method,
        dtype=np.float32, chunks=(images.chunks[1], images.chunks[2], (3 + channels,)),
        drop_axis=[0, 3], new_axis=[2],
        meta=np.empty((0, 0, 0), np.float32),
    )  # fmt: skip
    dask.compute(
        da.to_zarr(maps[..., :3], str(normals_store), compute=False),
        da.to_zarr(maps[..., 3:], str(albedo_store), compute=False),
    )


def _tiles(shape: tuple[int, int], tile: int) -> list[tuple[slice, slice]]:
    return [
        (slice(r, min(r + tile, shape[0])), slice(c, min(c + tile, shape[1])))
        for r in range(0, shape[0], tile)
        for c in range(0, shape[1], tile)
    ]


def _grown(
    window: tuple[slice, slice], shape: tuple[int, int], overlap: int
) -> tuple[slice, slice]:
    rows, columns = window
    return (
        slice(max(rows.start - overlap, 0), min(rows.stop + overlap, shape[0])),
        slice(max(columns.start - overlap, 0), min(columns.stop + overlap, shape[1])),
    )


def _local(inner: tuple[slice, slice], outer: tuple[slice, slice]) -> tuple[slice, slice]:
    """``inner`` (image coordinates) in the coordinates of the window ``outer`` that holds it."""
    return tuple(
        slice(a.start - b.start, a.stop - b.start) for a, b in zip(inner, outer, strict=True)
    )


def _integrate_tile(
    normals_store: str, scratch: str, i: int, grown: tuple[slice, slice], mask: np.ndarray,
    components: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """Integrate grown tile ``i`` (a task): its depth and piece labels go to the scratch store;
    returns the global component of each of its pieces (``(count,)``)."""
    import scipy.ndimage

    zarr = require_extra("zarr")

    from brdfkit.vision.normal_integration import least_squares_integration

    labels, count = scipy.ndimage.label(mask)
    depth = np.full(mask.shape, np.nan)
    if count:
        normals = np.asarray(zarr.open_array(normals_store, mode="r")[grown], dtype=np.float64)
        depth = least_squares_integration(normals, mask)
    store = zarr.open_group(scratch, mode="r+")
    h, w = mask.shape
    store["depth"][i, :h, :w] = depth
    store["labels"][i, :h, :w] = labels
    of_piece = np.zeros(count + 1, dtype=np.int64)
    of_piece[labels[mask]] = components[mask]
    return of_piece[1:]


def _tile_of(scratch: str, i: int, grown: tuple[slice, slice]) -> tuple[np.ndarray, np.ndarray]:
    zarr = require_extra("zarr")

    store = zarr.open_group(scratch, mode="r")
    h, w = grown[0].stop - grown[0].start, grown[1].stop - grown[1].start
    return store["depth"][i, :h, :w], store["labels"][i, :h, :w]


def _overlap(scratch: str, i: int, j: int, grown_i: tuple, grown_j: tuple) -> np.ndarray:
    """Rows ``(piece of i, piece of j, sum of z_j - z_i, pixels)`` over the overlap of grown
    tiles ``i`` and ``j`` (a task)."""
    common = tuple(slice(max(a.start, b.start), min(a.stop, b.stop))
                   for a, b in zip(grown_i, grown_j, strict=True))  # fmt: skip
    depth_i, labels_i = (x[_local(common, grown_i)] for x in _tile_of(scratch, i, grown_i))
    depth_j, labels_j = (x[_local(common, grown_j)] for x in _tile_of(scratch, j, grown_j))
    both = (labels_i > 0) & (labels_j > 0)
    if not both.any():
        return np.zeros((0, 4))
    pairs, inverse, counts = np.unique(
        np.stack([labels_i[both], labels_j[both]], axis=1), axis=0, return_inverse=True,
        return_counts=True,
    )  # fmt: skip
    sums = np.bincount(inverse.ravel(), (depth_j - depth_i)[both])
    return np.column_stack([pairs, sums, counts]).astype(np.float64)


def _shifted_core(scratch: str, i: int, window: tuple, grown: tuple, constants: np.ndarray):
    """The core of grown tile ``i`` plus its pieces' constants (NaN off the mask)."""
    depth, labels = _tile_of(scratch, i, grown)
    return (depth + np.concatenate([[np.nan], constants])[labels])[_local(window, grown)]


def _core_minima(scratch, i, window, grown, constants, components, count) -> np.ndarray:
    """The least shifted depth of each global component in tile ``i``'s core (a task)."""
    core = _shifted_core(scratch, i, window, grown, constants)
    nearest = np.full(count + 1, np.inf)
    inside = components > 0
    np.minimum.at(nearest, components[inside], core[inside])
    return nearest


def _write_core(scratch, i, window, grown, constants, components, nearest, depth_store) -> None:
    """Write tile ``i``'s core, each component's nearest pixel at 0 (a task)."""
    zarr = require_extra("zarr")

    core = _shifted_core(scratch, i, window, grown, constants)
    out = np.where(components > 0, core - nearest[components], np.nan)
    zarr.open_array(depth_store, mode="r+")[window] = out


def integrate(
    normals_store: str | Path, mask: np.ndarray, depth_store: str | Path, *, tile: int,
    overlap: int = OVERLAP,
) -> None:  # fmt: skip
    """Orthographic depth of a large normal map, tile by tile, into a Zarr array ``(H, W)``.

    Each tile, grown by ``overlap`` pixels on every side, is integrated by
    :func:`brdfkit.vision.normal_integration.least_squares_integration` (a task per tile), which
    fixes one constant per connected piece of the tile's mask. The constants ``c`` of all pieces are
    then the least-squares solution of ``c_a - c_b = mean(z_b - z_a)`` over each pair of pieces
    that overlap (weighted by the overlap's pixel count), one piece per connected component of
    the whole mask held at 0. The depth of each tile's core is its grown depth plus its
    piece's constant; finally each component's nearest pixel is put at 0, as
    :func:`~brdfkit.vision.normal_integration.least_squares_integration` does.

    The grown tiles' depths wait in a scratch Zarr store beside ``depth_store`` (removed at the
    end); the client holds the mask and its component labels (5 bytes a pixel) and one
    constant per piece. For an integrable field this is the global solution up to each tile's
    own least-squares fit; across a non-integrable field the seams show as small steps of the
    overlaps' mismatch.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``tile`` below 16, or ``overlap`` below 1 or not below ``tile``.
    """
    import shutil

    import dask
    import scipy.ndimage
    import scipy.sparse
    import scipy.sparse.linalg

    zarr = require_extra("zarr")

    if tile < 16 or not 1 <= overlap < tile:
        raise ParameterError(f"tile must be >= 16 and 1 <= overlap < tile; got {tile}, {overlap}")
    shape = mask.shape
    windows = _tiles(shape, tile)
    grown = [_grown(w, shape, overlap) for w in windows]
    components, count = scipy.ndimage.label(mask)
    side = tile + 2 * overlap
    scratch = str(Path(depth_store).with_name(f".{Path(depth_store).name}.scratch"))
    group = zarr.open_group(scratch, mode="w")
    group.create_array("depth", shape=(len(windows), side, side), chunks=(1, side, side),
                       dtype="float64", fill_value=np.nan)  # fmt: skip
    group.create_array("labels", shape=(len(windows), side, side), chunks=(1, side, side),
                       dtype="int32", fill_value=0)  # fmt: skip
    try:
        delayed = dask.delayed(pure=False)
        pieces = dask.compute(*[
            delayed(_integrate_tile)(str(normals_store), scratch, i, g, mask[g], components[g])
            for i, g in enumerate(grown)
        ])  # fmt: skip
        offsets = np.cumsum([0] + [len(p) for p in pieces])  # first piece of each tile
        pairs = _neighbours(grown)
        stats = dask.compute(*[
            delayed(_overlap)(scratch, i, j, grown[i], grown[j]) for i, j in pairs
        ])  # fmt: skip
        rows, columns, values, targets = [], [], [], []
        for (i, j), table in zip(pairs, stats, strict=True):
            for la, lb, total, pixels in table:
                weight = np.sqrt(pixels)
                rows += [len(targets)] * 2
                columns += [offsets[i] + int(la) - 1, offsets[j] + int(lb) - 1]
                values += [weight, -weight]
                targets.append(total / pixels * weight)
        anchored: set[int] = set()
        for i, of_piece in enumerate(pieces):  # each component's first piece is held at 0
            for piece, component in enumerate(of_piece):
                if int(component) not in anchored:
                    anchored.add(int(component))
                    rows.append(len(targets))
                    columns.append(offsets[i] + piece)
                    values.append(1.0)
                    targets.append(0.0)
        system = scipy.sparse.csr_matrix((values, (rows, columns)),
                                         shape=(len(targets), offsets[-1]))  # fmt: skip
        constants = scipy.sparse.linalg.lsqr(system, np.asarray(targets), atol=1e-14,
                                             btol=1e-14)[0]  # fmt: skip
        per_tile = [constants[offsets[i] : offsets[i + 1]] for i in range(len(windows))]
        minima = dask.compute(*[
            delayed(_core_minima)(scratch, i, w, g, per_tile[i], components[w], count)
            for i, (w, g) in enumerate(zip(windows, grown, strict=True))
        ])  # fmt: skip
        nearest = np.min(np.stack(minima), axis=0) if minima else np.full(count + 1, np.inf)
        zarr.open_array(str(depth_store), mode="w", shape=shape, chunks=(tile, tile),
                        dtype="float64", fill_value=np.nan)  # fmt: skip
        dask.compute(*[
            delayed(_write_core)(scratch, i, w, g, per_tile[i], components[w], nearest,
                                 str(depth_store))
            for i, (w, g) in enumerate(zip(windows, grown, strict=True))
        ])  # fmt: skip
    finally:
        shutil.rmtree(scratch, ignore_errors=True)  # our scratch store only


def _neighbours(grown: list[tuple[slice, slice]]) -> list[tuple[int, int]]:
    """Pairs of grown tiles that overlap."""
    pairs = []
    for i, a in enumerate(grown):
        for j in range(i + 1, len(grown)):
            b = grown[j]
            if all(x.start < y.stop and y.start < x.stop for x, y in zip(a, b, strict=True)):
                pairs.append((i, j))
    return pairs
