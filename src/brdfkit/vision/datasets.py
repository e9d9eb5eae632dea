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

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from brdfkit import io
from brdfkit._array import normalize
from brdfkit.vision.photometric_stereo import fit_circle, sphere_normals

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
        if self.images.ndim != 4:
            raise ValueError(f"images must have shape (N, H, W, C), got {self.images.shape}")
        n_lights, height, width, channels = self.images.shape
        if n_lights < 3:
            raise ValueError(f"photometric stereo needs at least 3 images, got {n_lights}")
        if self.light_directions.shape != (n_lights, 3):
            raise ValueError(
                f"light_directions must have shape ({n_lights}, 3) to match the images, got "
                f"{self.light_directions.shape}"
            )
        if self.mask.shape != (height, width):
            raise ValueError(f"mask must have shape {(height, width)}, got {self.mask.shape}")
        if not self.mask.any():
            raise ValueError(f"mask of {self.name!r} has no pixels set")
        if self.normals is not None and self.normals.shape != (height, width, 3):
            raise ValueError(
                f"normals must have shape {(height, width, 3)}, got {self.normals.shape}"
            )
        if self.light_intensities is not None and self.light_intensities.shape != (
            n_lights,
            channels,
        ):
            raise ValueError(
                f"light_intensities must have shape {(n_lights, channels)}, got "
                f"{self.light_intensities.shape}"
            )


def read_image(path: str | Path) -> np.ndarray:
    """Read an image as float32 ``(H, W, C)`` in [0, 1] without its alpha channel.

    :func:`brdfkit.io.read_image` (16-bit PNGs kept at 16 bits, integer codes divided by their
    type's maximum), then any alpha channel dropped.
    """
    image = io.read_image(path)
    return image[..., :-1] if image.shape[2] in (2, 4) else image


def read_mask(path: str | Path) -> np.ndarray:
    """Read a mask image as bool ``(H, W)``: pixels whose brightest channel exceeds one half."""
    return read_image(path).max(axis=2) > 0.5


def read_normal_map(path: str | Path) -> np.ndarray:
    """Decode a 16-bit (or 8-bit) RGB normal-map PNG: ``n = 2 v / v_max - 1``, ``(H, W, 3)``."""
    image = read_image(path)
    if image.shape[2] != 3:
        raise ValueError(f"normal map {str(path)!r} must have 3 channels, got {image.shape[2]}")
    return 2.0 * image.astype(np.float64) - 1.0


def write_normal_map(path: str | Path, normals: ArrayLike) -> None:
    """Encode unit normals ``(H, W, 3)`` as a 16-bit RGB PNG, ``v = round(65535 (n + 1) / 2)``."""
    import cv2

    normals = np.asarray(normals, dtype=np.float64)
    if normals.ndim != 3 or normals.shape[2] != 3:
        raise ValueError(f"normals must have shape (H, W, 3), got {normals.shape}")
    encoded = np.round(np.clip((normals + 1) / 2, 0, 1) * 65535).astype(np.uint16)
    if not cv2.imwrite(str(path), encoded[..., ::-1]):
        raise ValueError(f"cannot write normal map {str(path)!r}")


def _read_rows(path: Path, columns: int, skip: int = 0) -> np.ndarray:
    """A text table of ``columns`` floats per row (``skip`` header lines)."""
    if not path.is_file():
        raise ValueError(f"file {str(path)!r} does not exist")
    try:
        table = np.loadtxt(path, ndmin=2, skiprows=skip)
    except ValueError as error:
        raise ValueError(f"cannot parse {str(path)!r}: {error}") from error
    if table.shape[1] != columns:
        raise ValueError(f"{str(path)!r} must have {columns} columns, got {table.shape[1]}")
    return table


def _stack(paths: list[Path], step: int, callback: Callback | None) -> np.ndarray:
    """Read images into one ``(N, H, W, C)`` float32 array, every ``step``-th pixel."""
    if step < 1:
        raise ValueError(f"step must be a positive integer, got {step}")
    first = read_image(paths[0])[::step, ::step]
    stack = np.empty((len(paths), *first.shape), dtype=np.float32)
    stack[0] = first
    for k, path in enumerate(paths[1:], start=1):
        image = read_image(path)[::step, ::step]
        if image.shape != first.shape:
            raise ValueError(
                f"image {str(path)!r} has shape {image.shape}, expected {first.shape} like "
                f"{str(paths[0])!r}"
            )
        stack[k] = image
        if callback is not None:
            callback(k + 1, len(paths))
    return stack


def _unit_rows(lights: np.ndarray, source: str) -> np.ndarray:
    """Rows normalised to unit length; zero or non-finite rows are an error."""
    length = np.linalg.norm(lights, axis=1, keepdims=True)
    if not np.all(np.isfinite(length)) or np.any(length == 0):
        raise ValueError(f"light directions from {source} must be finite and non-zero")
    return lights / length


def load_diligent(
    folder: str | Path, *, step: int = 1, callback: Callback | None = None
) -> PhotometricStereoData:
    """Load one object in the DiLiGenT layout (see the module docstring).

    Images are divided by ``light_intensities.txt`` per light and channel; ``Normal_gt.mat`` is
    read with ``scipy.io.loadmat`` when present. ``step`` keeps every ``step``-th row and column.

    References
    ----------
    B. Shi et al., IEEE TPAMI 41(2), 2019.
    """
    import scipy.io

    folder = Path(folder)
    listing = folder / "filenames.txt"
    if not listing.is_file():
        raise ValueError(f"{str(folder)!r} is not a DiLiGenT folder: no filenames.txt")
    names = listing.read_text().split()
    if len(names) < 3:
        raise ValueError(f"photometric stereo needs at least 3 images, {listing} lists {names}")
    lights = _read_rows(folder / "light_directions.txt", 3)
    if len(lights) != len(names):
        raise ValueError(
            f"light_directions.txt has {len(lights)} rows but filenames.txt lists {len(names)}"
        )
    images = _stack([folder / name for name in names], step, callback)
    intensities = None
    intensity_file = folder / "light_intensities.txt"
    if intensity_file.is_file():
        intensities = _read_rows(intensity_file, images.shape[3] if images.shape[3] > 1 else 3)
        if len(intensities) != len(names):
            raise ValueError(
                f"light_intensities.txt has {len(intensities)} rows, expected {len(names)}"
            )
        if images.shape[3] == 1:
            intensities = intensities.mean(axis=1, keepdims=True)
        if np.any(intensities <= 0):
            raise ValueError("light_intensities.txt must hold positive intensities")
        images /= intensities[:, None, None, :].astype(np.float32)
    mask = read_mask(folder / "mask.png")[::step, ::step]
    normals = None
    if (folder / "Normal_gt.mat").is_file():
        normals = np.asarray(scipy.io.loadmat(folder / "Normal_gt.mat")["Normal_gt"], float)
        normals = normals[::step, ::step]
    return PhotometricStereoData(
        images=images,
        light_directions=_unit_rows(lights, str(folder / "light_directions.txt")),
        mask=mask,
        normals=normals,
        light_intensities=intensities,
        name=folder.name.removesuffix("PNG"),
    )


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
    """
    folder = Path(folder)
    listing = folder.parent / f"{folder.name}.txt"
    if not listing.is_file():
        raise ValueError(f"{str(folder)!r} is not a psm object folder: no {listing.name} beside it")
    lines = listing.read_text().split()
    count = int(lines[0])
    if count < 3 or len(lines) != count + 2:
        raise ValueError(f"{str(listing)!r} must list a count >= 3, the images and the mask")

    def resolve(entry: str) -> Path:
        # Listed paths start with a "psmImages/" folder that this copy of the set does not have.
        direct = folder.parent / entry
        return direct if direct.exists() else folder.parent.joinpath(*Path(entry).parts[1:])

    images = _stack([resolve(entry) for entry in lines[1:-1]], step, callback)
    full_mask = read_mask(resolve(lines[-1]))
    mask = full_mask[::step, ::step]
    if light_directions is None:
        lights = _read_rows(folder.parent / "lights.txt", 3, skip=1)
        source = str(folder.parent / "lights.txt")
    else:
        lights = np.asarray(light_directions, dtype=np.float64)
        source = "light_directions"
    if lights.shape != (count, 3):
        raise ValueError(f"{source} must have shape ({count}, 3), got {lights.shape}")
    normals = None
    if folder.name in PSM_SPHERES:  # fitted at full resolution, then subsampled like the mask
        c_x, c_y, radius = fit_circle(full_mask)
        normals = sphere_normals(full_mask.shape, (c_x, c_y), radius)[0][::step, ::step]
    return PhotometricStereoData(
        images=images,
        light_directions=_unit_rows(lights, source),
        mask=mask,
        normals=normals,
        name=folder.name,
    )


def load_dataset(
    path: str | Path, *, step: int = 1, callback: Callback | None = None
) -> PhotometricStereoData:
    """Load a DiLiGenT folder (has ``filenames.txt``) or a psm object folder (``<obj>.txt``
    beside it), whichever ``path`` is."""
    path = Path(path)
    if not path.is_dir():
        raise ValueError(f"data set folder {str(path)!r} does not exist")
    if (path / "filenames.txt").is_file():
        return load_diligent(path, step=step, callback=callback)
    if (path.parent / f"{path.name}.txt").is_file():
        return load_psm(path, step=step, callback=callback)
    raise ValueError(
        f"{str(path)!r} is neither a DiLiGenT folder (filenames.txt) nor a psm object folder "
        f"({path.name}.txt beside it)"
    )


def save_diligent(data: PhotometricStereoData, folder: str | Path) -> None:
    """Write ``data`` in the DiLiGenT layout (16-bit PNGs; :func:`load_diligent` reads it back).

    Images are multiplied back by ``data.light_intensities`` (when set) and quantised to 16 bits,
    values above 1 clipping; the mask is 8-bit, the normals go to ``Normal_gt.mat``.
    """
    import cv2
    import scipy.io

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    raw = data.images.astype(np.float64)
    if data.light_intensities is not None:
        raw = raw * data.light_intensities[:, None, None, :]
    raw = np.round(np.clip(raw, 0, 1) * 65535).astype(np.uint16)
    names = [f"{k + 1:03d}.png" for k in range(len(raw))]
    for name, image in zip(names, raw, strict=True):
        pixels = image[..., ::-1] if image.shape[2] == 3 else image
        if not cv2.imwrite(str(folder / name), pixels):
            raise ValueError(f"cannot write {str(folder / name)!r}")
    (folder / "filenames.txt").write_text("\n".join(names) + "\n")
    np.savetxt(folder / "light_directions.txt", data.light_directions, fmt="%.8f")
    if data.light_intensities is not None:
        np.savetxt(folder / "light_intensities.txt", data.light_intensities, fmt="%.8f")
    cv2.imwrite(str(folder / "mask.png"), data.mask.astype(np.uint8) * 255)
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


def load_normal_integration(folder: str | Path) -> NormalIntegrationData:
    """Load ``normal_map.png``, ``mask.png``, ``depth_gt.npz`` and ``K.txt`` from ``folder``.

    References
    ----------
    X. Cao et al., "Bilateral normal integration", ECCV 2022; B. Shi et al., TPAMI 2019.
    """
    folder = Path(folder)
    normals = read_normal_map(folder / "normal_map.png")
    mask = read_mask(folder / "mask.png")
    depth_file = folder / "depth_gt.npz"
    if not depth_file.is_file():
        raise ValueError(f"file {str(depth_file)!r} does not exist")
    with np.load(depth_file) as archive:
        depth = np.asarray(archive["depth_gt"], dtype=np.float64)
    camera = _read_rows(folder / "K.txt", 3)
    if depth.shape != mask.shape or normals.shape[:2] != mask.shape or camera.shape != (3, 3):
        raise ValueError(
            f"inconsistent shapes in {str(folder)!r}: normals {normals.shape}, mask "
            f"{mask.shape}, depth {depth.shape}, K {camera.shape}"
        )
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
    """
    if n_columns < 1 or n_rows < 1 or n_columns * n_rows < 3:
        raise ValueError(f"need at least 3 lights, got a {n_rows} x {n_columns} grid")
    if not 0 < max_polar_angle < np.pi / 2:
        raise ValueError(f"max_polar_angle must be in (0, pi/2), got {max_polar_angle}")
    x = np.arange(n_columns) - (n_columns - 1) / 2
    y = (n_rows - 1) / 2 - np.arange(n_rows)
    spacing = np.tan(max_polar_angle) / max(np.hypot(x[0], y[0]), 1e-12)
    gx, gy = np.meshgrid(x * spacing, y * spacing)
    lights = np.stack([gx.ravel(), gy.ravel(), np.ones(gx.size)], axis=1)
    return lights / np.linalg.norm(lights, axis=1, keepdims=True)


def cast_shadows(
    height: ArrayLike, light_directions: ArrayLike, pixel_size: float = 1.0
) -> np.ndarray:
    """Which pixels of a height field each distant light reaches (cast shadows only).

    A pixel is shadowed when, marching from it towards the light across the image one pixel at
    a time, the height field rises above the ray: ``h(p + t d) > h(p) + t s tan(elevation)``
    with ``d`` the light's image-plane direction (rows go down: ``d = (l_x, -l_y) / |..|``) and
    ``s = pixel_size``. Vectorised over pixels; loops over lights and march steps only.

    Parameters
    ----------
    height : (H, W) height towards the camera, in the units of ``pixel_size``; NaN where there
        is no surface (never occludes).
    light_directions : (N, 3) directions towards the lights.
    pixel_size : footprint of a pixel on the surface (orthographic approximation).

    Returns
    -------
    (N, H, W) bool, True where the light is not blocked.

    References
    ----------
    N. L. Max, "Horizon mapping: shadows for bump-mapped surfaces", The Visual Computer 4(2),
    1988.
    """
    height = np.asarray(height, dtype=np.float64)
    lights = np.asarray(light_directions, dtype=np.float64)
    if height.ndim != 2 or lights.ndim != 2 or lights.shape[1] != 3:
        raise ValueError(
            f"height must be (H, W) and light_directions (N, 3), got "
            f"{height.shape} and {lights.shape}"
        )
    if not pixel_size > 0:
        raise ValueError(f"pixel_size must be positive, got {pixel_size}")
    surface = np.isfinite(height)
    if not surface.any():
        raise ValueError("height has no finite value")
    h = np.where(surface, height, -np.inf)
    span = height[surface].max() - height[surface].min()
    rows, columns = np.indices(height.shape)
    lit = np.ones((len(lights), *height.shape), dtype=bool)
    for k, (l_x, l_y, l_z) in enumerate(lights):
        planar = np.hypot(l_x, l_y)
        if planar < 1e-12 or l_z <= 0:
            continue
        rise = pixel_size * l_z / planar
        d_col, d_row = l_x / planar, -l_y / planar
        for t in range(1, int(span / rise) + 2):
            r = np.rint(rows + t * d_row).astype(int)
            c = np.rint(columns + t * d_col).astype(int)
            inside = (r >= 0) & (r < height.shape[0]) & (c >= 0) & (c < height.shape[1])
            occluder = np.where(
                inside, h[r.clip(0, height.shape[0] - 1), c.clip(0, height.shape[1] - 1)], -np.inf
            )
            lit[k] &= ~(occluder > h + t * rise)
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

    References
    ----------
    J. F. Blinn, "Models of light reflection for computer synthesized pictures", SIGGRAPH 1977;
    R. J. Woodham, Optical Engineering 19(1), 1980.
    """
    normals = np.asarray(normals, dtype=np.float64)
    mask = np.asarray(mask, dtype=bool)
    lights = _unit_rows(np.asarray(light_directions, dtype=np.float64), "light_directions")
    if normals.ndim != 3 or normals.shape[2] != 3 or mask.shape != normals.shape[:2]:
        raise ValueError(
            f"normals must be (H, W, 3) and mask (H, W), got {normals.shape} and {mask.shape}"
        )
    albedo = np.atleast_1d(np.asarray(albedo, dtype=np.float64))
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
