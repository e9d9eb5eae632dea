"""Environment maps: distant light from an equirectangular (lat-long) image.

:class:`EnvironmentMap` interpolates the image bilinearly, samples directions in proportion to
luminance·sin θ, and tabulates the irradiance of the normals for the diffuse part of a BRDF.
Its tables are made when first used and only as far as used (a map only looked up builds no
sampling distribution; the irradiance table is built by the columns that lookups read), and are
shared by maps of equal pixels (keyed by their digest): the same file read again is not a new
map. The irradiance table has a second level of cache on disk (:func:`use_table_store`), so
that a new process reading the same map does not build it again; the sampling weights are
made again (writing a map's megabytes of them cost its first image more than reading them
saves a later process).

References
----------
.. [1] P. Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 1998.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §14.2.4.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import math
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    clamp,
    constant,
    namespace,
    normalize,
    safe_div,
    to_numpy,
)
from brdfkit.errors import FormatError, ParameterError
from brdfkit.geometry import (
    cartesian_to_spherical,
    spherical_to_cartesian,
)
from brdfkit.light.base import STRENGTH, Light, LightSample, _batch
from brdfkit.params import check_number


def _sampling_weights(image: np.ndarray, compensate: bool = False) -> np.ndarray:
    """Texel weights (H, W) of an environment map's light sampling: luminance·sin θ.

    A bilinear lookup inside a pixel mixes its 3×3 neighbourhood. The luminance sampled is
    the mean of two texel values: the lookup's mean over the texel (:func:`_texel_mean`,
    proportional to the power the texel sends) and the neighbourhood's maximum (which keeps
    L/pdf within twice its bound next to a bright sun), a defensive mixture [1]_; plus a
    floor of 10⁻³ of its mean so that every direction the lookup can light has a positive
    density. With ``compensate`` the map's sin θ-weighted mean luminance is subtracted
    first, clipped at zero (:attr:`EnvironmentMap.compensated`).

    References
    ----------
    .. [1] T. Hesterberg, "Weighted average importance sampling and defensive mixture
           distributions", *Technometrics* 37(2), 1995.
    """
    from brdfkit.io import REC709_WEIGHTS

    height = image.shape[0]
    sin_theta = np.sin((np.arange(height) + 0.5) * math.pi / height)[:, None]
    lum = np.empty(image.shape[:2])
    if image.shape[2] == 3:  # image @ weights, by blocks of rows: the float64 copy of the
        # pixels that the product makes is one block's, not the map's (the same products)
        weights = np.array(REC709_WEIGHTS)
        step = max(1, _LUMINANCE_BLOCK // image.shape[1])
        for start in range(0, height, step):
            np.matmul(image[start : start + step], weights, out=lum[start : start + step])
    else:
        np.mean(image, axis=2, dtype=np.float64, out=lum)
    if compensate:  # the luminance's mean over the sphere
        mean = float(lum.sum(axis=1) @ sin_theta[:, 0]) / (float(np.sum(sin_theta)) * lum.shape[1])
    # the two filters' row passes, then their column passes into the memory the row passes
    # are done with: a map's weights are megabytes, and fresh memory is slow to touch
    tent, maxima = _tent_rows(lum), _row_maximum(lum)
    _column_maximum(maxima, out=lum)  # the 3×3 maximum (_neighbourhood_maximum)
    peak = _tent_columns(tent, out=maxima)  # the texel mean (_texel_mean)
    peak += lum
    peak *= 0.5
    floor = 1e-3 * max(peak.mean(), 1e-12)
    if compensate:
        np.maximum(np.subtract(peak, mean, out=peak), 0.0, out=peak)
    peak += floor
    return np.multiply(peak, sin_theta, out=peak)


def _texel_mean(values: np.ndarray) -> np.ndarray:
    """The mean over each texel of the bilinear interpolation of a lat-long map's texel
    ``values`` ``(H, W)`` (rows clamped at the poles, columns wrapping around), a new array:
    along each axis the interpolant between neighbouring centres averages to
    ``(v[i-1] + 6 v[i] + v[i+1]) / 8`` over texel i."""
    return _tent_columns(_tent_rows(values), out=np.empty_like(values))


def _tent_rows(values: np.ndarray) -> np.ndarray:
    """``v[i-1] + 6 v[i] + v[i+1]`` of each texel of ``values`` ``(H, W)`` and those above and
    below it (rows clamped at the poles), a new array: :func:`_texel_mean`'s first step."""
    rows = values * 6.0
    rows[1:] += values[:-1]  # the row above (the pole's own)
    rows[:1] += values[:1]
    rows[:-1] += values[1:]  # the row below
    rows[-1:] += values[-1:]
    return rows


def _tent_columns(rows: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``(r[j-1] + 6 r[j] + r[j+1]) / 64`` of each texel of ``rows`` ``(H, W)`` and those
    before and after it (columns wrapping around), into ``out`` (not ``rows``):
    :func:`_texel_mean`'s second step."""
    np.multiply(rows, 6.0, out=out)
    out[:, 1:] += rows[:, :-1]  # the column before, wrapping
    out[:, :1] += rows[:, -1:]
    out[:, :-1] += rows[:, 1:]  # the column after, wrapping
    out[:, -1:] += rows[:, :1]
    out *= 1 / 64
    return out


_LUMINANCE_BLOCK = 1 << 15
"""Pixels per block of :func:`_sampling_weights`' luminance."""


def _holds_radiance(image: np.ndarray) -> bool:
    """Whether every value of ``image`` is finite and non-negative, by two reductions and no
    temporary arrays (a map's pixels are megabytes): its minimum is NaN where a value is, and
    NaN ≥ 0 is false; its maximum is infinite where a value is."""
    return bool(image.min() >= 0) and bool(image.max() < np.inf)


def _neighbourhood_maximum(values: np.ndarray) -> np.ndarray:
    """The maximum over each texel's 3×3 neighbourhood of a lat-long map's ``values``
    ``(H, W)``: rows clamped at the poles, columns wrapping around. SciPy's
    ``maximum_filter(values, 3, mode=("nearest", "wrap"))`` (equal to the bit: a maximum
    rounds nothing), written out because importing ``scipy.ndimage`` costs a new process
    more than this whole function (0.3 s against 2 ms for a 1024 × 512 map)."""
    return _column_maximum(_row_maximum(values), out=np.empty_like(values))


def _row_maximum(values: np.ndarray) -> np.ndarray:
    """The maximum of each texel of ``values`` ``(H, W)`` and those above and below it (rows
    clamped at the poles), a new array: :func:`_neighbourhood_maximum`'s first step."""
    rows = values.copy()
    np.maximum(rows[1:], values[:-1], out=rows[1:])  # the row above (the pole's own)
    np.maximum(rows[:-1], values[1:], out=rows[:-1])  # the row below
    return rows


def _column_maximum(rows: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The maximum of each texel of ``rows`` ``(H, W)`` and those before and after it
    (columns wrapping around), into ``out`` (not ``rows``): :func:`_neighbourhood_maximum`'s
    second step."""
    out[...] = rows
    np.maximum(out[:, 1:], rows[:, :-1], out=out[:, 1:])  # the column before, wrapping
    np.maximum(out[:, :1], rows[:, -1:], out=out[:, :1])
    np.maximum(out[:, :-1], rows[:, 1:], out=out[:, :-1])  # the column after, wrapping
    np.maximum(out[:, -1:], rows[:, :1], out=out[:, -1:])
    return out


@dataclass(frozen=True, eq=False)
class EnvironmentMap(Light):
    r"""Distant radiance from an equirectangular (lat-long) image, bilinearly interpolated.

    The map follows :func:`brdfkit.light.spherical_harmonics.latlong_directions`: row 0 at +z (θ =
    0), column 0 starting at φ = 0 (+x) with φ growing towards +y. ``rotation`` (a 3×3 matrix)
    takes map directions to world directions. Importance sampling draws pixels from a
    piecewise-constant distribution proportional to luminance·sin θ (the mean of the bilinear
    lookup's mean over the texel and its 3×3 maximum, since the lookup mixes neighbours, plus a
    small floor so that every direction the bilinear lookup can light has a positive density;
    :func:`_sampling_weights`), with solid-angle pdf
    :math:`p_\omega = p_{uv} / (2\pi^2 \sin\theta)`.

    Parameters
    ----------
    image : (H, W, C) non-negative radiance (W·m⁻²·sr⁻¹).
    scale : multiplies the radiance.
    rotation : (3, 3) rotation matrix map → world (default identity).

    References
    ----------
    .. [1] P. Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 1998.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §14.2.4.

    Examples
    --------
    A map from an array: bright upper half (row 0 is the zenith), dark lower half:

    >>> import numpy as np
    >>> image = np.zeros((8, 16, 3))
    >>> image[:4] = 1.0
    >>> env = EnvironmentMap(image, scale=0.5)
    >>> up_and_down = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    >>> env.incident_radiance(np.zeros(3), up_and_down).tolist()
    [[0.5, 0.5, 0.5], [0.0, 0.0, 0.0]]

    A sample's value is the radiance over the density of :meth:`pdf` in its direction:

    >>> sample = env.sample(np.zeros(3), np.array([0.3, 0.2]))
    >>> bool(sample.wi[2] > 0), bool(np.isclose(sample.pdf, env.pdf(np.zeros(3), sample.wi)))
    (True, True)
    >>> (sample.value * sample.pdf).round(12).tolist()
    [0.5, 0.5, 0.5]
    """

    image: Any = None
    scale: float = 1.0
    rotation: Any = None

    def __post_init__(self) -> None:
        img = to_numpy(check_number("image", self.image)) if self.image is not None else None
        if img is None or img.ndim != 3 or img.shape[0] < 2 or img.shape[1] < 2:
            shape = None if img is None else img.shape
            raise ParameterError(
                f"image must be an (H, W, C) lat-long array with H, W >= 2; got {shape}"
            )
        if not _holds_radiance(img):
            raise ParameterError("image must hold finite, non-negative radiance values")
        STRENGTH.check("scale", self.scale)
        rot = np.eye(3) if self.rotation is None else check_number("rotation", self.rotation)
        rot = np.asarray(to_numpy(rot), dtype=float)
        finite = rot.shape == (3, 3) and np.all(np.isfinite(rot))
        if not finite or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6):
            raise ParameterError(f"rotation must be a 3×3 rotation matrix; got {rot!r}")
        object.__setattr__(self, "image", np.ascontiguousarray(img, dtype=np.float32))
        object.__setattr__(self, "rotation", rot)
        object.__setattr__(self, "channels", img.shape[2])

    @functools.cached_property
    def _distribution(self):
        """The light-sampling distribution of :meth:`sample` and :meth:`pdf`
        (:func:`_sampling_weights`), made when first needed: a map only looked up (the atlas's
        quadrature spheres, whose Monte Carlo renders sample :attr:`compensated`) never
        pays for it. Shared by maps of the same pixels (:func:`_content_table`)."""
        from brdfkit.sampling import Distribution2D

        return _content_table(
            self._pixels_key,
            "distribution",
            lambda: Distribution2D(_sampling_weights(self.image)),
        )

    @functools.cached_property
    def _pixels_key(self) -> tuple[Any, ...]:
        """The pixels' key of :func:`_content_table`: their shape and SHA-256 digest."""
        return (self.image.shape, hashlib.sha256(memoryview(self.image)).digest())

    @functools.cached_property
    def compensated(self) -> EnvironmentMap:
        r"""The same map with the light-sampling distribution MIS should combine with BRDF
        sampling: proportional to :math:`\max(L - \bar L, 0)\sin\theta` plus the floor,
        with :math:`\bar L` the map's mean luminance over the sphere.

        Multiple importance sampling with BRDF sampling covers the directions where the map is
        near its mean well already; taking the mean out of the light's density spends its
        samples on what is brighter (Karlík et al.'s MIS compensation), and the floor keeps the
        density positive wherever the map lights, so either strategy alone stays unbiased. Same
        radiance, rotation and scale; only :meth:`sample` and :meth:`pdf` differ.

        References
        ----------
        .. [1] O. Karlík, M. Šik, P. Vévoda, T. Skřivan, J. Křivánek, "MIS compensation:
           optimizing sampling techniques in multiple importance sampling", *ACM Trans.
           Graph.* 38(6), 2019.
        """
        from brdfkit.sampling import Distribution2D

        view = copy.copy(self)
        distribution = _content_table(
            self._pixels_key,
            "compensated",
            lambda: Distribution2D(_sampling_weights(self.image, compensate=True)),
        )
        view.__dict__["_distribution"] = distribution
        view.__dict__["compensated"] = view
        return view

    @classmethod
    def from_file(
        cls, path: str | Path, scale: float = 1.0, rotation: Any = None
    ) -> EnvironmentMap:
        """Read a lat-long ``.hdr``/``.exr`` (or LDR, decoded to linear) environment map."""
        from brdfkit.io import read_image

        image = read_image(path)
        if Path(path).suffix.lower() not in (".hdr", ".exr", ".pfm"):
            from brdfkit.io import srgb_decode

            image = srgb_decode(image)
        if not _holds_radiance(image):
            raise FormatError(path, "holds NaN, infinite or negative values; a map holds radiance")
        return cls(image[..., :3], scale=scale, rotation=rotation)

    @classmethod
    def from_mirror_ball(
        cls, photo: Any, height: int = 256, width: int = 512, scale: float = 1.0
    ) -> EnvironmentMap:
        """Convert a photograph of a mirror ball (cropped to the ball) to a lat-long map.

        Orthographic view along the camera's −z; the camera frame (x right, y up, z towards the
        camera) maps to the world frame as world = (z_cam, x_cam, y_cam): world +z is the
        photo's up and world +x points towards the camera. For a world direction d the ball
        normal reflecting the view direction v = +x into d is n = (d + v)/|d + v|, seen at
        photo coordinates (x, y) = (n·x_cam, n·y_cam). Directions right behind the ball
        (d ≈ −v) are not seen and come out poorly sampled.
        """
        from brdfkit.light.spherical_harmonics import latlong_directions

        photo = to_numpy(photo).astype(np.float32)
        if photo.ndim != 3 or photo.shape[0] < 2:
            raise ParameterError(f"photo must be an (H, W, C) image of the ball; got {photo.shape}")
        d = latlong_directions(height, width)
        v = np.array([1.0, 0.0, 0.0])
        n = d + v
        n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
        x_cam, y_cam = n[..., 1], n[..., 2]
        ph, pw = photo.shape[:2]
        col = (x_cam + 1) / 2 * pw - 0.5
        row = (1 - y_cam) / 2 * ph - 0.5
        image = _bilinear_np(photo, row, col)
        return cls(image, scale=scale)

    def _map_coordinates(self, wi: Array) -> tuple[Array, Array, Array]:
        """Unit world ``wi`` as map coordinates: x = φ/2π ∈ [0, 1), y = θ/π, and θ."""
        xp = namespace(wi)
        wi_map = xp.matmul(wi, asarray(self.rotation, xp, like=wi))
        theta, phi = cartesian_to_spherical(wi_map)
        x = xp.remainder(phi, constant(2 * math.pi, phi)) / (2 * math.pi)
        return x, theta / math.pi, theta

    def _lookup(self, wi: Array) -> Array:
        xp = namespace(wi)
        x, y, _ = self._map_coordinates(wi)
        height, width = self.image.shape[:2]
        image = asarray(self.image, xp, like=wi)
        value = _bilinear(image, y * height - 0.5, x * width - 0.5)
        return value * self.scale

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        value = self._lookup(normalize(wi))
        return xp.broadcast_to(value, (*_batch(points, wi), value.shape[-1]))

    def sample(self, points: Array, u: Array) -> LightSample:
        xp = namespace(points, u)
        uv, pdf_uv = self._distribution.sample(asarray(u[..., :2], xp, like=points))
        theta, phi = uv[..., 1] * math.pi, uv[..., 0] * (2 * math.pi)
        wi_map = spherical_to_cartesian(theta, phi)
        wi = xp.matmul(wi_map, xp.permute_dims(asarray(self.rotation, xp, like=points), (1, 0)))
        pdf = _solid_angle_pdf(pdf_uv, theta)
        value = safe_div(self._lookup(wi), pdf[..., None])
        batch = _batch(points, wi)
        inf = xp.full(batch, math.inf, dtype=points.dtype)
        return LightSample(
            xp.broadcast_to(wi, (*batch, 3)),
            xp.broadcast_to(value, (*batch, value.shape[-1])),
            xp.broadcast_to(pdf, batch),
            inf,
            False,
        )

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        x, y, theta = self._map_coordinates(normalize(wi))
        pdf_uv = self._distribution.pdf(xp.stack([x, y], axis=-1))
        pdf = _solid_angle_pdf(pdf_uv, theta)
        return xp.broadcast_to(pdf, _batch(points, wi))

    def irradiance(self, normals: Array) -> Array:
        r"""Irradiance :math:`E(n) = \int L(\omega) \max(n\cdot\omega, 0)\,d\omega` on a
        surface with unit world normal ``normals`` ``(..., 3)``; ``(..., C)``.

        A Lambertian surface of albedo ρ under the map reflects exactly :math:`\rho E(n)/\pi`
        towards every viewer above it, with no Monte Carlo. E is read from
        :meth:`irradiance_table` by bilinear interpolation; only the table's columns that
        ``normals`` read are built (a sphere seen from one side needs half of them).
        """
        xp = namespace(normals)
        x, y, _ = self._map_coordinates(normalize(normals))
        rows, cols = IRRADIANCE_GRID
        nodes = self._irradiance_nodes.columns(_node_columns(to_numpy(x) * cols, cols))
        table = asarray(nodes, xp, like=normals)
        return _bilinear(table, y * (rows - 1), x * cols) * self.scale

    def prepare_irradiance(self) -> None:
        """Make the part of :attr:`irradiance_table` that needs no normals now: the pixels'
        moments per cell, where no column of the table is built yet (one read from the
        table store has some, and may never need them). The compiled renderer runs it on a
        helper thread while the caller traces its G-buffer, before the first tile's
        lookups ask for columns; the table is the same.

        Examples
        --------
        >>> import numpy as np
        >>> env = EnvironmentMap(np.ones((8, 16, 3)))
        >>> env.prepare_irradiance()
        >>> env.irradiance(np.array([0.0, 0.0, 1.0])).round(6).tolist()  # πL, L = 1
        [3.141593, 3.141593, 3.141593]
        """
        self._irradiance_nodes.cells()

    @functools.cached_property
    def _irradiance_nodes(self) -> _IrradianceNodes:
        """The map's :class:`_IrradianceNodes`, shared by maps of equal pixels."""
        return _content_table(
            self._pixels_key,
            "irradiance",
            lambda: _IrradianceNodes(self.image, self._table_key("irradiance")),
        )

    def _table_key(self, name: str) -> str:
        """The key of the table ``name`` on disk: SHA-256 of the pixels' digest, their shape
        and type, the irradiance cells and node grid, ``name`` and :data:`TABLE_FORMAT`."""
        shape, digest = self._pixels_key
        parts = (TABLE_FORMAT, name, shape, self.image.dtype.str, IRRADIANCE_CELLS, IRRADIANCE_GRID)
        return hashlib.sha256(digest + repr(parts).encode()).hexdigest()

    @functools.cached_property
    def irradiance_table(self) -> np.ndarray:
        r"""E at map-frame normals on a lat-long node grid, ``(97, 192, C)`` float32.

        Row ``i`` holds θ = πi/96 (both poles included), column ``j`` φ = 2πj/192. Each
        value is a normalised quadrature over the map's pixels grouped into 48×96 cells:

        .. math:: E(n) = \pi\,\frac{\sum_c \max(n\cdot M_c, 0)}{\sum_c \max(n\cdot A_c, 0)},
           \quad M_c = \sum_{p\in c} L_p \,\Delta\Omega_p\, \omega_p,
           \quad A_c = \sum_{p\in c} \Delta\Omega_p\, \omega_p,

        with :math:`\Delta\Omega_p = \tfrac{2\pi}{W}(\cos\theta_p^- - \cos\theta_p^+)` the
        exact solid angle of pixel p and :math:`\omega_p` its centre. Because
        :math:`n\cdot\omega` is linear in ω, the cell moments M_c are exact for every cell
        wholly above or below n's horizon; only cells that straddle it (where the cosine is
        below the cell's size, π/48) err, by at most their radiance × solid angle × π/96.
        The denominator is the same quadrature of L = 1 (exactly π in the limit): it removes
        the quadrature's own error, so a constant map gives E = πL to rounding (white-out).
        The grid's bilinear interpolation errs by at most ~h|∇E|/4 (h = π/96) at the kink
        that a point-like source puts at its terminator, and by O(h²) elsewhere.

        The sums over cells take a few cells per row of cells and normal, not all of them:
        cells wholly above n's horizon add n·M_c and form an arc of columns, summed from
        prefix sums; cells wholly below add 0; only the few across the horizon are clamped
        one by one (:func:`_clamped_sums`). The table equals the sum over every cell to
        rounding. Once the compiled layer has handed in its tools (:func:`compiled_lookups`),
        the moments and the sums are numba kernels (``light/_environment_kernels.py``; tests
        hold them equal to the NumPy code to rounding).

        References
        ----------
        .. [1] R. Ramamoorthi, P. Hanrahan, "An efficient representation for irradiance
               environment maps", SIGGRAPH 2001 (the irradiance map; here by direct
               summation instead of spherical harmonics, which ring at a sun).
        """
        return self._irradiance_nodes.columns(np.arange(IRRADIANCE_GRID[1]))


CACHED_MAPS = 4
"""Maps whose tables (:func:`_content_table`) a process keeps, the most recently used."""

_TABLES: OrderedDict[tuple[Any, ...], dict[str, Any]] = OrderedDict()
_TABLES_LOCK = threading.Lock()


def _content_table(key: tuple[Any, ...], name: str, build: Callable[[], Any]) -> Any:
    """The table ``name`` of a map's pixels, made by ``build`` once per content: maps of
    equal pixels (the same file read again, another scale or rotation) share their sampling
    distributions and irradiance table, which depend on the pixels alone. ``key``: the
    pixels' shape and SHA-256 digest (``EnvironmentMap._pixels_key``); the tables of the
    :data:`CACHED_MAPS` most recently used maps are kept."""
    with _TABLES_LOCK:
        tables = _TABLES.pop(key, {})
        _TABLES[key] = tables
        while len(_TABLES) > CACHED_MAPS:
            _TABLES.popitem(last=False)
    if name not in tables:  # built outside the lock: two threads may both build it
        tables[name] = build()
    return tables[name]


@dataclass(frozen=True)
class TableStore:
    """A second level of the maps' table cache, on disk: ``load(kind, key)`` gives the arrays
    stored under ``key`` (a dict of names to NumPy arrays) or ``None``; ``writer(kind, key)``
    gives a function that stores such arrays there (its place fixed when asked, the write
    made later, atomically), or ``None`` where nothing is stored; none of them raises. What
    ``load`` gives is checked before it is used (shape, type, finite values): a bad entry is
    built again, never trusted."""

    load: Callable[[str, str], dict[str, np.ndarray] | None]
    writer: Callable[[str, str], Callable[[dict[str, np.ndarray]], None] | None]


TABLE_FORMAT = 1
"""Version of the irradiance table's layout on disk, part of its key."""

_STORE: list[TableStore] = []


_LOAD_LOCK = threading.Lock()


def _load_table(kind: str, key: str) -> dict[str, np.ndarray] | None:
    """The table store's arrays under ``kind``/``key`` (or ``None``), one load at a time: a
    new map's irradiance table may be looked up on a helper thread and on the caller's at
    once (:meth:`EnvironmentMap.prepare_irradiance` and a first lookup), and reading an
    ``.npz`` parses each array's header with :func:`ast.literal_eval`, whose AST constructor
    keeps its recursion depth per interpreter in CPython 3.11: two threads parsing at once
    can fail with ``SystemError: AST constructor recursion depth mismatch`` (seen here;
    python/cpython#106905)."""
    if not _STORE:
        return None
    with _LOAD_LOCK:
        return _STORE[0].load(kind, key)


_WRITER: list[Any] = []
"""The table store's writer thread (a one-thread executor: tables are written in the order
asked), made when first needed."""
_PENDING: list[Any] = []
"""The futures of the writes not yet seen done."""
_PENDING_LOCK = threading.Lock()


def _store_later(kind: str, key: str, arrays: dict[str, np.ndarray]) -> None:
    """Store ``arrays`` under ``kind``/``key`` in the table store (if any), where it points
    now, on the store's writer thread, so that a new map's first image does not wait for its
    tables' disk copy; ``arrays`` must not change afterwards. Each entry is written
    atomically (whole or absent), and the writer is a non-daemon thread: the interpreter
    finishes the pending writes before it exits (:func:`wait_for_table_store` waits for
    them now)."""
    write = _STORE[0].writer(kind, key) if _STORE else None
    if write is None:
        return
    from concurrent.futures import ThreadPoolExecutor

    with _PENDING_LOCK:
        if not _WRITER:
            _WRITER.append(ThreadPoolExecutor(1, thread_name_prefix="brdfkit-table-store"))
        _PENDING[:] = [future for future in _PENDING if not future.done()]
        _PENDING.append(_WRITER[0].submit(write, arrays))


def wait_for_table_store() -> None:
    """Wait until the table store has written every table asked of it so far (the disk
    copies :func:`use_table_store` describes are made in the background).

    Examples
    --------
    >>> wait_for_table_store()
    """
    with _PENDING_LOCK:
        pending = list(_PENDING)
    for future in pending:
        future.result()


def use_table_store(store: TableStore | None) -> TableStore | None:
    """Keep the maps' irradiance tables in ``store`` too (``None``: in memory only); returns
    the store used until now. :mod:`brdfkit.compiled.cache` gives its own when imported (the
    kernel cache's folder, ``$BRDFKIT_CACHE_DIR``). Tables are stored in the background, in
    order (:func:`wait_for_table_store`).

    Examples
    --------
    >>> previous = use_table_store(None)  # in memory only
    >>> use_table_store(previous) is None
    True
    """
    previous = _STORE[0] if _STORE else None
    _STORE[:] = [] if store is None else [store]
    return previous


def clear_table_cache() -> None:
    """Forget every map's cached tables (:func:`_content_table`): the next map pays for its
    own, as the first map a process reads does.

    Examples
    --------
    >>> clear_table_cache()
    """
    with _TABLES_LOCK:
        _TABLES.clear()


IRRADIANCE_CELLS = (48, 96)
"""Cells (rows, columns) the map's pixels are grouped into for :meth:`EnvironmentMap.irradiance`."""


IRRADIANCE_GRID = (97, 192)
"""Node grid (rows with both poles, columns) of :meth:`EnvironmentMap.irradiance_table`."""


class _IrradianceNodes:
    """:attr:`EnvironmentMap.irradiance_table` of a lat-long ``image``, built column by column
    as lookups need them (:meth:`columns`)."""

    def __init__(self, image: np.ndarray, key: str) -> None:
        self._image = image
        rows, cols = IRRADIANCE_GRID
        self._table = np.zeros((rows, cols, image.shape[2]), np.float32)
        self._built = np.zeros(cols, bool)
        self._lock = threading.Lock()
        self._cells: tuple[np.ndarray, _CellBounds] | None = None
        self._key = key
        stored = _load_table("irradiance", key)
        if stored is not None and self._valid(stored):
            self._table[...] = stored["table"]
            self._built[...] = stored["built"]

    def _valid(self, stored: dict[str, np.ndarray]) -> bool:
        """Whether ``stored`` is a table of this map's shape and type, finite where built."""
        table, built = stored.get("table"), stored.get("built")
        return (
            isinstance(table, np.ndarray)
            and isinstance(built, np.ndarray)
            and table.dtype == self._table.dtype
            and table.shape == self._table.shape
            and built.dtype == bool
            and built.shape == self._built.shape
            and bool(np.isfinite(table[:, built]).all())
        )

    def cells(self) -> None:
        """Group the pixels into the cells' moments (:func:`_cell_moments`) now, unless they
        are grouped or some column is built already (a table from the store, whose columns
        may be all its lookups read)."""
        with self._lock:
            if self._cells is None and not self._built.any():
                self._make_cells()

    def _make_cells(self) -> None:
        """The cells' moments and bounds, the lock held; the pixels are let go."""
        shape = self._image.shape[:2]
        moments = _cell_moments(self._image, IRRADIANCE_CELLS)
        self._cells = moments, _cell_bounds(shape, IRRADIANCE_CELLS)
        self._image = None  # the moments are all the table needs

    def columns(self, needed: np.ndarray) -> np.ndarray:
        """The table, ``(97, 192, C)`` float32, with (at least) the node columns ``needed``
        (increasing, each once) built; the others are not to be read."""
        with self._lock:
            missing = needed[~self._built[needed]]
            if missing.size:
                if self._cells is None:
                    self._make_cells()
                rows, cols = IRRADIANCE_GRID
                theta = np.linspace(0.0, math.pi, rows)
                phi = missing * (2 * math.pi / cols)
                sums = _node_sums(*self._cells, theta, phi).reshape(rows, missing.size, -1)
                self._table[:, missing] = math.pi * sums[..., 1:] / sums[..., :1]
                self._built[missing] = True
                arrays = {"table": self._table.copy(), "built": self._built.copy()}
                _store_later("irradiance", self._key, arrays)
        return self._table


def _node_columns(col: np.ndarray, cols: int) -> np.ndarray:
    """The node columns a bilinear lookup at fractional columns ``col`` reads (the one at or
    below, and the next, wrapping), unique."""
    col = np.nan_to_num(np.asarray(col, dtype=np.float64).ravel(), nan=0.0, posinf=0.0)
    read = np.zeros(cols, bool)  # marked, not sorted: a tile's normals are thousands
    read[np.clip(np.floor(col), 0, cols - 1).astype(np.int64)] = True
    read |= np.roll(read, 1)  # and the next column, wrapping
    return np.flatnonzero(read)


def _pixel_centres(count: int, span: float) -> np.ndarray:
    """Centres of ``count`` equal pixels over [0, span]."""
    return (np.arange(count) + 0.5) * (span / count)


def _cell_moments(image: np.ndarray, cells: tuple[int, int]) -> np.ndarray:
    r"""Per cell of a lat-long ``image``, :math:`A_c = \sum_p \Delta\Omega_p\omega_p` and
    :math:`M_c = \sum_p L_p\Delta\Omega_p\omega_p` as ``(rows, cols, 1 + C, 3)`` float64 (A
    first, then M per channel); pixel (r, c) goes to cell ``(r·rows // H, c·cols // W)``.

    :math:`\Delta\Omega_p\omega_p` is a product of a row's factor (:math:`\Delta\Omega
    \sin\theta`, :math:`\Delta\Omega\cos\theta`) and a column's (:math:`\cos\varphi`,
    :math:`\sin\varphi`, 1), so the sums are two weighted sums over runs of pixels: over each
    cell's rows with the row factors, then over its columns with the column factors (float64;
    a cell holding no pixel has zero moments). Once the compiled layer has handed in its
    tools (:func:`compiled_lookups`), one pass of a numba kernel over the pixels instead
    (``_environment_kernels.cell_moments``)."""
    height, width, channels = image.shape
    rows, cols = cells
    row_factors, col_factors = _pixel_factors(height, width)
    if _KERNEL_TOOLS:  # one pass over the pixels by a numba kernel instead
        from brdfkit.light._environment_kernels import cell_moments

        moments = np.zeros((rows, cols, 1 + channels, 3))
        row_cell = np.arange(height) * rows // height
        col_cell = np.arange(width) * cols // width
        kernel = cell_moments(_KERNEL_TOOLS[0])
        kernel(image, row_factors, col_factors, row_cell, col_cell, moments)
        return moments
    per_row = np.empty((2, rows, width, 1 + channels))
    for kind, factor in enumerate(row_factors):
        area = _run_sums(factor, rows, axis=0)  # the sums of a map of ones
        per_row[kind, ..., 0] = area[:, None]
        per_row[kind, ..., 1:] = _run_sums(image * factor[:, None, None], rows, axis=0)
    sin_rows, cos_rows = per_row  # (rows, W, 1 + C)
    sums = [
        _run_sums(part * factor[:, None], cols, axis=1)  # (rows, cols, 1 + C)
        for part, factor in zip((sin_rows, sin_rows, cos_rows), col_factors, strict=True)
    ]
    return np.stack(sums, axis=-1)


def _pixel_factors(height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    r"""The row factors ``(2, H)`` (:math:`\Delta\Omega\sin\theta`,
    :math:`\Delta\Omega\cos\theta`) and column factors ``(3, W)`` (:math:`\cos\varphi`,
    :math:`\sin\varphi`, 1) of the pixels of a lat-long map (:func:`_cell_moments`)."""
    edges = np.arange(height + 1) * (math.pi / height)
    solid_angle = (2 * math.pi / width) * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    theta, phi = _pixel_centres(height, math.pi), _pixel_centres(width, 2 * math.pi)
    row_factors = solid_angle * np.stack([np.sin(theta), np.cos(theta)])
    return row_factors, np.stack([np.cos(phi), np.sin(phi), np.ones(width)])


def _run_sums(values: np.ndarray, groups: int, axis: int) -> np.ndarray:
    """Sums of ``values`` over the ``groups`` runs of its ``axis`` that pixel i of n belongs
    to, group ``i·groups // n``; 0 for a group no pixel falls in."""
    count = values.shape[axis]
    first = np.flatnonzero(np.diff(np.arange(count) * groups // count, prepend=-1))
    shape = list(values.shape)
    shape[axis] = groups
    sums = np.zeros(shape)
    index = [slice(None)] * values.ndim
    index[axis] = np.arange(count)[first] * groups // count
    sums[tuple(index)] = np.add.reduceat(values, first, axis=axis, dtype=np.float64)
    return sums


@dataclass(frozen=True)
class _CellBounds:
    """Where the pixel centres of a lat-long map's cells lie: each cell row's centre polar
    angle ``theta`` (rows,) and chord radius ``radius`` (rows,), a bound on the distance from
    the cell's centre direction to any of its pixel centres, and each cell column's centre
    azimuth ``phi`` (cols,), increasing in [0, 2π)."""

    theta: np.ndarray
    radius: np.ndarray
    phi: np.ndarray


def _cell_bounds(shape: tuple[int, int], cells: tuple[int, int]) -> _CellBounds:
    """:class:`_CellBounds` of the pixel centres of an ``(H, W)`` map in ``cells``."""
    (height, width), (rows, cols) = shape, cells

    def extents(count: int, groups: int, span: float) -> tuple[np.ndarray, np.ndarray]:
        centres = _pixel_centres(count, span)
        group = np.arange(count) * groups // count  # empty groups (zero moments) fall between
        first = np.minimum(np.searchsorted(group, np.arange(groups)), count - 1)
        last = np.maximum(np.searchsorted(group, np.arange(groups), side="right") - 1, 0)
        return centres[first], centres[last]

    theta_low, theta_high = extents(height, rows, math.pi)
    phi_low, phi_high = extents(width, cols, 2 * math.pi)
    theta, phi = (theta_low + theta_high) / 2, (phi_low + phi_high) / 2
    half_width = np.max(phi_high - phi_low) / 2
    # the farthest pixel centre of a cell lies at one of its corners or edge midpoints
    corners = [(t, dp) for t in (theta_low, theta, theta_high) for dp in (0.0, half_width)]
    radius = np.max([_chord(theta, t, dp) for t, dp in corners], axis=0)  # (rows,)
    return _CellBounds(theta, radius * (1 + 1e-6) + 1e-12, phi)


def _chord(theta: np.ndarray, other: np.ndarray, dphi: float) -> np.ndarray:
    """|ω(θ, 0) − ω(θ', Δφ)|, the chord between two directions."""
    cos_angle = np.cos(theta) * np.cos(other) + np.sin(theta) * np.sin(other) * np.cos(dphi)
    return np.sqrt(np.maximum(2 - 2 * cos_angle, 0.0))


def _clamped_sums(
    moments: np.ndarray, bounds: _CellBounds, theta: np.ndarray, phi: np.ndarray
) -> np.ndarray:
    r""":math:`\sum_c \max(n\cdot v_c, 0)` for each vector v of the cells' ``moments``
    ``(rows, cols, K, 3)`` and each normal n of the node grid ``theta`` × ``phi``;
    ``(nodes, K)`` float64.

    Every v_c is a non-negative sum of the cell's pixel-centre directions ω_p, so a cell
    whose ω_p all lie above n's horizon adds n·v_c, one whose ω_p all lie below adds 0, and
    only the cells in between need their clamped dot products. With :math:`\omega_c` the
    cell's centre direction and ρ its chord radius, :math:`|n\cdot\omega_p - n\cdot\omega_c|
    \le \rho`: in cell row r, :math:`n\cdot\omega_c = a + b\cos(\varphi_c - \varphi_n)`
    (:math:`a = n_z\cos\theta_r`, :math:`b = \sin\theta_n\sin\theta_r`), so the cells above
    form an arc of columns around :math:`\varphi_n` (summed from prefix sums) and those in
    between two short arcs beside it. The work per normal is a few cells per row instead of
    every cell.
    """
    rows, cols, k, _ = moments.shape
    t, p = (grid.ravel() for grid in np.meshgrid(theta, phi, indexing="ij"))
    normals = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
    nodes = normals.shape[0]
    turns, inner, outer = _arcs(bounds, theta)
    inner = np.repeat(inner, phi.size, axis=1)  # (rows, nodes)
    outer = np.repeat(outer, phi.size, axis=1)
    lo_in, hi_in = _arc_indices(turns, p, inner, cols)
    lo_out, hi_out = _arc_indices(turns, p, outer, cols)
    # the cells in between: [lo_out, lo_in) and [hi_in, hi_out), the rest of the outer arc
    whole = hi_out - lo_out >= cols
    lo_out, hi_out = np.where(whole, lo_in, lo_out), np.where(whole, lo_in + cols, hi_out)
    above = np.zeros((nodes, 3 * k))
    total = np.zeros((nodes, k))
    normals32 = normals.astype(np.float32)
    vectors, prefix = _turn_prefix(moments)
    for r in range(rows):
        above += np.take(prefix[r], hi_in[r], axis=0)
        above -= np.take(prefix[r], lo_in[r], axis=0)
        vectors32 = vectors[r].astype(np.float32).reshape(cols, k, 3)
        for start, stop in ((lo_out[r], lo_in[r]), (hi_in[r], hi_out[r])):
            count = stop - start
            nonempty = np.flatnonzero(count)
            if nonempty.size == 0:
                continue
            first = np.cumsum(count) - count
            cell = (np.repeat(start - first, count) + np.arange(first[-1] + count[-1])) % cols
            v, n = np.take(vectors32, cell, axis=0), np.repeat(normals32, count, axis=0)
            dots = v[..., 0] * n[:, :1] + v[..., 1] * n[:, 1:2] + v[..., 2] * n[:, 2:]
            total[nonempty] += np.add.reduceat(
                np.maximum(dots, 0.0), first[nonempty], axis=0, dtype=np.float64
            )
    total += np.einsum("nkj,nj->nk", above.reshape(nodes, k, 3), normals)
    return total


def _arcs(bounds: _CellBounds, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three turns of the cell columns' azimuths (an arc around any φ ∈ [0, 2π) is one index
    range of them), and the half-widths of the arcs of cells wholly above the horizon of
    normals at polar angles ``theta`` and of cells not wholly below it, ``(rows, node
    rows)`` each (:func:`_clamped_sums`: a and b depend on the normal's θ alone)."""
    turns = np.concatenate([bounds.phi - 2 * math.pi, bounds.phi, bounds.phi + 2 * math.pi])
    a = np.cos(bounds.theta)[:, None] * np.cos(theta)  # (rows, node rows)
    b = np.sin(bounds.theta)[:, None] * np.sin(theta)
    radius = bounds.radius[:, None]
    return turns, _half_arc(a, b, radius), _half_arc(a, b, -radius)


def _turn_prefix(moments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cells' ``moments`` ``(rows, cols, K, 3)`` as ``(rows, cols, 3K)`` vectors, and each
    row's prefix sums over three turns of its columns, ``(rows, 3 cols + 1, 3K)``."""
    rows, cols = moments.shape[:2]
    vectors = np.ascontiguousarray(moments.reshape(rows, cols, -1))
    prefix = np.zeros((rows, 3 * cols + 1, vectors.shape[2]))
    np.cumsum(np.tile(vectors, (1, 3, 1)), axis=1, out=prefix[:, 1:])
    return vectors, prefix


def _node_sums(
    moments: np.ndarray, bounds: _CellBounds, theta: np.ndarray, phi: np.ndarray
) -> np.ndarray:
    """:func:`_clamped_sums`, by its numba kernel (``_environment_kernels.clamped_sums``, on
    the kernels' threads, a block of node rows each) once the compiled layer has handed in
    its tools (:func:`compiled_lookups`), else by NumPy."""
    if not _KERNEL_TOOLS:
        return _clamped_sums(moments, bounds, theta, phi)
    from brdfkit.light._environment_kernels import clamped_sums

    tools = _KERNEL_TOOLS[0]
    kernel = clamped_sums(tools)
    prefix = _turn_prefix(moments)[1]
    components = np.ascontiguousarray(moments.transpose(0, 1, 3, 2))  # (rows, cols, 3, K)
    turns, inner, outer = _arcs(bounds, theta)
    out = np.zeros((theta.size * phi.size, moments.shape[2]))
    blocks = np.linspace(0, theta.size, min(theta.size, 4 * tools.threads()) + 1).astype(int)

    def block(b: int) -> None:
        kernel(prefix, components, turns, theta, phi, inner, outer, blocks[b], blocks[b + 1], out)

    tools.run_tasks(block, range(blocks.size - 1), tools.threads())
    return out


def _half_arc(a: np.ndarray, b: np.ndarray, level: float) -> np.ndarray:
    """Half-width w of the arc of azimuths Δφ with a + b cos Δφ > ``level`` (b ≥ 0):
    π for all of them, −1 for none."""
    with np.errstate(divide="ignore", invalid="ignore"):
        threshold = (level - a) / b
    width = np.arccos(np.clip(threshold, -1.0, 1.0))
    width = np.where(threshold < -1, math.pi, np.where(threshold > 1, -1.0, width))
    flat = b <= 0  # a pole: the row is wholly on one side
    return np.where(flat, np.where(a > level, math.pi, -1.0), width)


def _arc_indices(
    turns: np.ndarray, phi: np.ndarray, width: np.ndarray, cols: int
) -> tuple[np.ndarray, np.ndarray]:
    """Index range [lo, hi) into three turns of column azimuths ``turns`` of the columns with
    |φ_c − φ| < ``width`` (cyclic), widened by a rounding margin; all ``cols`` columns
    ``[cols, 2 cols)`` for a width of π, none (an empty range at φ) for a negative one."""
    margin = 1e-9
    lo = np.searchsorted(turns, phi - np.maximum(width, 0) - margin, side="left")
    hi = np.searchsorted(turns, phi + width + margin, side="right")
    centre = np.searchsorted(turns, phi, side="left")
    lo, hi = np.where(width < 0, centre, lo), np.where(width < 0, centre, np.minimum(hi, lo + cols))
    full = width >= math.pi
    return np.where(full, cols, lo), np.where(full, 2 * cols, hi)


_KERNEL_TOOLS: list[Any] = []
""":mod:`brdfkit.compiled.kernel_tools` once handed in (:func:`compiled_lookups`)."""


def compiled_lookups(dtype: Any, tools: Any) -> Any:
    """This module's lookups as numba functions for compiled kernels in ``dtype``: the map
    coordinates of a direction, the bilinear radiance, the pdf and the map's sampling, and
    ``tables(env)``, the arrays they read (``light/_environment_kernels.py``; tests bind each
    function to the code here). ``tools`` is :mod:`brdfkit.compiled.kernel_tools`, handed in
    by the caller (the compiled layer sits above this one); from then on the irradiance
    table's sums over cells are a numba kernel too (:func:`_node_sums`)."""
    from brdfkit.light import _environment_kernels

    _KERNEL_TOOLS[:] = [tools]  # the table builds use numba kernels too from now on
    return _environment_kernels.lookups(np.dtype(dtype).type, tools)


def compiled_texel_search(tools: Any) -> Any:
    """The map's texel search of :func:`compiled_lookups` (``sample_texels``, the same for
    every dtype: float64 variates) built from ``tools`` alone, without handing them to the
    table builds as :func:`compiled_lookups` does: for compiling it ahead of a kernel that
    calls it."""
    from brdfkit.light import _environment_kernels

    return _environment_kernels.texel_sampler(tools)


def _solid_angle_pdf(pdf_uv: Array, theta: Array) -> Array:
    """p_ω = p_uv / (2π² sin θ) of a lat-long map; 0 at the poles (sin θ ≤ 0 after rounding)."""
    return safe_div(pdf_uv, 2 * math.pi**2 * clamp(namespace(theta).sin(theta), 0.0))


def _bilinear(image: Array, row: Array, col: Array) -> Array:
    """Bilinear lookup of an (H, W, C) lat-long image at fractional pixel coordinates.

    Columns wrap around (φ is periodic); rows clamp at the poles.
    """
    xp = namespace(image, row)
    height, width, channels = image.shape
    r0f, c0f = xp.floor(row), xp.floor(col)
    fr, fc = (row - r0f)[..., None], (col - c0f)[..., None]
    r_index = xp.astype(r0f, xp.int64)
    r0 = xp.clip(r_index, 0, height - 1)
    r1 = xp.clip(r_index + 1, 0, height - 1)
    c0 = xp.remainder(xp.astype(c0f, xp.int64), width)
    c1 = xp.remainder(c0 + 1, width)
    flat = xp.reshape(image, (height * width, channels))
    shape = (*row.shape, channels)

    def at(r: Array, c: Array) -> Array:
        return xp.reshape(xp.take(flat, xp.reshape(r * width + c, (-1,)), axis=0), shape)

    top = at(r0, c0) * (1 - fc) + at(r0, c1) * fc
    bottom = at(r1, c0) * (1 - fc) + at(r1, c1) * fc
    return top * (1 - fr) + bottom * fr


def _bilinear_np(image: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """Bilinear lookup clamped at every border (for photographs, which do not wrap)."""
    from scipy.ndimage import map_coordinates

    return np.stack(
        [
            map_coordinates(image[..., c], [row, col], order=1, mode="nearest")
            for c in range(image.shape[2])
        ],
        axis=-1,
    )


__all__ = [
    "CACHED_MAPS",
    "TABLE_FORMAT",
    "EnvironmentMap",
    "TableStore",
    "clear_table_cache",
    "compiled_lookups",
    "compiled_texel_search",
    "use_table_store",
    "wait_for_table_store",
]
