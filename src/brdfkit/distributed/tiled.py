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

from brdfkit.errors import FormatError, ParameterError

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
    import zarr

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
    import zarr

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


def _integrate_tile(normals_store: str, mask: np.ndarray, window: tuple[slice, slice]) -> tuple:
    """Least-squares depth of one grown tile and the labels of its mask's pieces (a task)."""
    import scipy.ndimage
    import zarr

    from brdfkit.vision.integration import least_squares_integration

    normals = np.asarray(zarr.open_array(normals_store, mode="r")[window], dtype=np.float64)
    depth = np.full(mask.shape, np.nan)
    labels, count = scipy.ndimage.label(mask)
    if count:
        depth = least_squares_integration(normals, mask)
    return depth, labels, count


def integrate(
    normals_store: str | Path,
    mask: np.ndarray,
    depth_store: str | Path,
    *,
    tile: int,
    overlap: int = OVERLAP,
) -> None:
    """Orthographic depth of a large normal map, tile by tile, into a Zarr array ``(H, W)``.

    Each tile, grown by ``overlap`` pixels on every side, is integrated by
    :func:`brdfkit.vision.integration.least_squares_integration` (a task per tile), which fixes
    one constant per connected piece of the tile's mask. The constants ``c`` of all pieces are
    then the least-squares solution of ``c_a - c_b = mean(z_b - z_a)`` over each pair of pieces
    that overlap (weighted by the overlap's pixel count), one piece per connected component of
    the whole mask held at 0. The depth of each tile's core is its grown depth plus its
    piece's constant; finally each component's nearest pixel is put at 0, as
    :func:`~brdfkit.vision.integration.least_squares_integration` does.

    For an integrable field this is the global solution up to each tile's own least-squares
    fit; across a non-integrable field the tiles' seams show as small steps of the overlap's
    mismatch.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``tile`` below 16, or ``overlap`` below 1 or not below ``tile``.
    """
    import dask
    import scipy.ndimage
    import scipy.sparse
    import scipy.sparse.linalg
    import zarr

    if tile < 16 or not 1 <= overlap < tile:
        raise ParameterError(f"tile must be >= 16 and 1 <= overlap < tile; got {tile}, {overlap}")
    shape = mask.shape
    windows = _tiles(shape, tile)
    grown = [_grown(w, shape, overlap) for w in windows]
    parts = dask.compute(*[
        dask.delayed(_integrate_tile, pure=False)(str(normals_store), mask[g], g) for g in grown
    ])  # fmt: skip
    offsets = np.cumsum([0] + [count for _, _, count in parts])  # piece index of tile i's label 1
    rows, columns, values, targets = [], [], [], []
    equation = 0
    for i, j in _neighbours(grown):
        (depth_i, labels_i, _), (depth_j, labels_j, _) = parts[i], parts[j]
        common = tuple(slice(max(a.start, b.start), min(a.stop, b.stop))
                       for a, b in zip(grown[i], grown[j], strict=True))  # fmt: skip
        local_i = tuple(
            slice(c.start - g.start, c.stop - g.start)
            for c, g in zip(common, grown[i], strict=True)
        )
        local_j = tuple(
            slice(c.start - g.start, c.stop - g.start)
            for c, g in zip(common, grown[j], strict=True)
        )
        a, b = labels_i[local_i], labels_j[local_j]
        both = (a > 0) & (b > 0)
        if not both.any():
            continue
        difference = (depth_j[local_j] - depth_i[local_i])[both]
        pairs, inverse, counts = np.unique(
            np.stack([a[both], b[both]], axis=1), axis=0, return_inverse=True, return_counts=True
        )
        sums = np.bincount(inverse.ravel(), difference)
        for (la, lb), total, count in zip(pairs, sums, counts, strict=True):
            weight = np.sqrt(count)
            rows += [equation, equation]
            columns += [offsets[i] + la - 1, offsets[j] + lb - 1]
            values += [weight, -weight]
            targets.append(total / count * weight)
            equation += 1
    # One piece per global component anchored at 0: its first piece in tile order.
    labels, components = scipy.ndimage.label(mask)
    anchored = set()
    for i, (g, (_, piece_labels, count)) in enumerate(zip(grown, parts, strict=True)):
        for piece in range(1, count + 1):
            component = int(labels[g][piece_labels == piece][0])
            if component not in anchored:
                anchored.add(component)
                rows.append(equation)
                columns.append(offsets[i] + piece - 1)
                values.append(1.0)
                targets.append(0.0)
                equation += 1
    system = scipy.sparse.csr_matrix((values, (rows, columns)), shape=(equation, offsets[-1]))
    constants = scipy.sparse.linalg.lsqr(system, np.asarray(targets), atol=1e-14, btol=1e-14)[0]
    depth_out = zarr.open_array(
        str(depth_store), mode="w", shape=shape, chunks=(tile, tile), dtype="float64",
        fill_value=np.nan,
    )  # fmt: skip
    nearest = np.full(components + 1, np.inf)
    cores = []
    for i, (w, g) in enumerate(zip(windows, grown, strict=True)):
        depth, piece_labels, _ = parts[i]
        shifted = (
            depth + np.concatenate([[np.nan], constants[offsets[i] : offsets[i + 1]]])[piece_labels]
        )
        core = shifted[
            tuple(slice(a.start - b.start, a.stop - b.start) for a, b in zip(w, g, strict=True))
        ]
        inside = mask[w]
        np.minimum.at(nearest, labels[w][inside], core[inside])
        cores.append(core)
    for w, core in zip(windows, cores, strict=True):
        depth_out[w] = np.where(mask[w], core - nearest[labels[w]], np.nan)


def _neighbours(grown: list[tuple[slice, slice]]) -> list[tuple[int, int]]:
    """Pairs of grown tiles that overlap."""
    pairs = []
    for i, a in enumerate(grown):
        for j in range(i + 1, len(grown)):
            b = grown[j]
            if all(x.start < y.stop and y.start < x.stop for x, y in zip(a, b, strict=True)):
                pairs.append((i, j))
    return pairs
