r"""RGL material database files (``.bsdf``, EPFL; Dupuy & Jakob 2018), evaluated like Mitsuba 3.

A ``.bsdf`` file is a *tensor file* (Mitsuba's ``TensorFile``): the 12 bytes
``"tensor_file\0"``, a version ``(1, 0)`` (two uint8), a uint32 field count, then per field a
uint16 name length, the name, a uint16 rank, a uint8 type code (1 uint8, 2 int8, 3 uint16,
4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64, 9 float16, 10 float32, 11 float64), a uint64 byte
offset and rank × uint64 sizes; the arrays follow, C-order, little-endian.

The BRDF is stored in the adaptive parameterisation of Dupuy & Jakob: for each incident
direction :math:`(\varphi_i, \theta_i)` on a grid, the reflected values live on the unit square
:math:`[0,1]^2` that the *visible normal distribution* (``vndf``) warps onto half vectors. To
evaluate :math:`f(\omega_i, \omega_o)` (:math:`\omega_i` here the viewing direction of the
measurement, brdfkit's ``wo``; :math:`\omega_o` the light, brdfkit's ``wi``):

1. :math:`\omega_m = \mathrm{normalize}(\omega_i + \omega_o)`, elevations by the stable
   :math:`\theta = 2\arcsin(\tfrac12\lVert\omega - \mathbf z\rVert)`, and
   :math:`u_m = (\sqrt{2\theta_m/\pi},\ (\varphi_m - \varphi_i + \pi)/2\pi \bmod 1)`
   (:math:`\varphi_m` alone for anisotropic data);
2. :math:`s = \mathrm{VNDF}^{-1}(u_m \mid \varphi_i, \theta_i)`, the inverse of the
   hierarchical bilinear warp (Mitsuba ``Marginal2D<Float, 2, true>::invert``), its tables
   interpolated linearly in :math:`(\varphi_i, \theta_i)`;
3. the channel values are the bilinear interpolant of ``rgb`` (or ``spectra``) at :math:`s`;
   if the ``jacobian`` flag is set they are multiplied by
   :math:`D(u_m) / (4\,\sigma(u_i))` (``ndf`` and projected area ``sigma``).

The result is :math:`f\cos\theta_o` (Mitsuba's ``eval``); brdfkit divides by the light's
cosine to return f. Anisotropic files whose φi grid covers 1/2 or 1/4 of the circle are mirrored
into it as Mitsuba does. Spectral files are converted to linear sRGB through the CIE 1931
observer (a channel outside the sRGB gamut clipped to 0), or kept spectral. Sampling is
cosine-weighted (:class:`CosineSampled`), not the luminance/VNDF warp of the paper.

References
----------
.. [1] J. Dupuy, W. Jakob, "An adaptive parameterization for efficient material acquisition
       and rendering", ACM TOG 37(6) (SIGGRAPH Asia), 2018.
.. [2] W. Jakob et al., Mitsuba 3: ``src/bsdfs/measured.cpp``,
       ``include/mitsuba/core/distr_2d.h`` (``Marginal2D``), ``include/mitsuba/core/tensor.h``,
       ``python/tensor_io.py``.
"""

from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit._array import Array, asarray, namespace
from brdfkit.brdf.base import result_shape
from brdfkit.errors import FormatError
from brdfkit.measured.tabulated import (
    CosineSampled,
    spectrum_to_rgb_matrix,
    wavelengths_problem,
)

_MAGIC = b"tensor_file\x00"
_DTYPES = {
    1: np.uint8,
    2: np.int8,
    3: np.uint16,
    4: np.int16,
    5: np.uint32,
    6: np.int32,
    7: np.uint64,
    8: np.int64,
    9: np.float16,
    10: np.float32,
    11: np.float64,
}


def read_tensor_file(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The named arrays of a Mitsuba tensor file (format in the module docstring).

    The arrays are read-only views of the file's bytes: a header can only declare arrays that
    the file holds, so nothing is allocated beyond the file itself.

    Raises
    ------
    FormatError
        Naming the file (and the field and byte offset), for a wrong magic string or version,
        a field name that is not UTF-8, an unknown type code, a shape larger than the file, or
        a truncated file.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``include/mitsuba/core/tensor.h``, ``tensor_io.py``.
    """
    path = Path(path)
    raw = path.read_bytes()
    if raw[:12] != _MAGIC:
        raise FormatError(path, f"does not start with 'tensor_file\\0'; got {raw[:12]!r}", offset=0)
    pos = 12
    try:
        version = struct.unpack_from("<BB", raw, pos)
        if version != (1, 0):
            raise FormatError(path, f"version {version}; expected (1, 0)", offset=pos)
        (count,) = struct.unpack_from("<I", raw, 14)
        pos, fields = 18, {}
        for _ in range(count):
            pos = _field(path, raw, pos, fields)
    except struct.error as error:
        raise FormatError(path, f"truncated in its header: {error}", offset=pos) from None
    return fields


def _field(path: Path, raw: bytes, pos: int, fields: dict[str, np.ndarray]) -> int:
    """Read the field whose header starts at byte ``pos`` into ``fields``; the next position.

    Raises
    ------
    struct.error
        When the header runs past the end of the file.
    FormatError
        For a name that is not UTF-8, an unknown type code, or data past the end of the file.
    """
    (length,) = struct.unpack_from("<H", raw, pos)
    encoded = raw[pos + 2 : pos + 2 + length]
    try:
        name = encoded.decode("utf8")
    except UnicodeDecodeError as error:
        reason = f"field name {encoded!r} is not UTF-8: {error.reason}"
        raise FormatError(path, reason, offset=pos) from None
    start = pos
    pos += 2 + length
    rank, code, offset = struct.unpack_from("<HBQ", raw, pos)
    pos += 11
    shape = struct.unpack_from(f"<{rank}Q", raw, pos)
    pos += 8 * rank
    if code not in _DTYPES:
        raise FormatError(path, f"unknown type code {code}", field=name, offset=start)
    if any(size > len(raw) for size in shape):
        raise FormatError(
            path,
            f"shape {shape} is larger than the file ({len(raw)} bytes)",
            field=name,
            offset=start,
        )
    dtype = np.dtype(_DTYPES[code]).newbyteorder("<")
    end = offset + math.prod(shape) * dtype.itemsize
    if end > len(raw):
        raise FormatError(
            path,
            f"truncated: the data of shape {shape} need bytes up to {end}, the file has {len(raw)}",
            field=name,
            offset=start,
        )
    fields[name] = np.frombuffer(raw, dtype, math.prod(shape), offset).reshape(shape)
    return pos


# --------------------------------------------------------------------------- Marginal2D
class _Marginal2D:
    """Mitsuba's ``Marginal2D<Float, Dimension, Continuous=true>``: a bilinear density on
    ``[0, 1]^2`` (``data`` of shape ``(*param sizes, h, w)``) with its inverse warp, linearly
    interpolated in the conditioning parameters. Tables are built in float32 with float64
    accumulation, as Mitsuba does.
    """

    def __init__(
        self, data: np.ndarray, params: list[np.ndarray], normalize: bool, sampling: bool
    ) -> None:
        *param_shape, h, w = data.shape
        if len(param_shape) != len(params):
            raise ValueError(f"data of shape {data.shape} does not match {len(params)} parameters")
        self.h, self.w = h, w
        self.params = [np.asarray(p, dtype=np.float64) for p in params]
        self.strides, slices = [0] * len(params), 1
        for i in range(len(params) - 1, -1, -1):
            self.strides[i] = slices if param_shape[i] > 1 else 0
            slices *= param_shape[i]
        d = np.asarray(data, dtype=np.float32).reshape(slices, h, w)
        norm = np.ones((slices, 1), dtype=np.float32)
        if sampling:
            terms = (0.5 / (w - 1)) * (d[:, :, :-1].astype(np.float64) + d[:, :, 1:])
            cond = np.cumsum(terms, axis=-1)  # (slices, h, w-1), sequential as Mitsuba's loop
            row_sum = cond[:, :, -1]
            marg = np.cumsum((0.5 / (h - 1)) * (row_sum[:, :-1] + row_sum[:, 1:]), axis=-1)
            if normalize:
                norm = (1.0 / marg[:, -1:]).astype(np.float32)
            self.cond = (cond.astype(np.float32) * norm[:, :, None]).reshape(slices, -1)
            self.marg = marg.astype(np.float32) * norm
        elif normalize:
            total = (d[:, :-1, :-1] + d[:, :-1, 1:] + d[:, 1:, :-1] + d[:, 1:, 1:]).astype(
                np.float64
            )
            scale = (0.5 / (w - 1)) * (0.5 / (h - 1))
            norm = (1.0 / (scale * total.sum(axis=(1, 2))))[:, None].astype(np.float32)
        self.data = (d.reshape(slices, -1) * norm).astype(np.float32)

    def _corners(self, params: list[Array], like: Array) -> list[tuple[Array, Array]]:
        """(slice index, weight) of each corner of the parameter cell, per point."""
        xp = namespace(like)
        corners = [(xp.zeros(like.shape, dtype=xp.int64), xp.ones_like(like))]
        for values, stride, p in zip(self.params, self.strides, params, strict=True):
            if values.size == 1:
                continue
            grid = asarray(values, xp, like=like)
            index = xp.clip(xp.searchsorted(grid, p, side="left"), 1, values.size - 1) - 1
            p0, p1 = xp.take(grid, index), xp.take(grid, index + 1)
            w1 = xp.clip((p - p0) / (p1 - p0), 0.0, 1.0)
            corners = [
                (s + (index + bit) * stride, w * (w1 if bit else 1 - w1))
                for s, w in corners
                for bit in (0, 1)
            ]
        return corners

    def _lookup(self, table: np.ndarray, corners: list, index: Array, mask: Any = None) -> Array:
        """Σ_corners weight · table[slice, index] (0 where ``mask`` is False)."""
        xp = namespace(index)
        flat = asarray(table.reshape(-1), xp, like=corners[0][1])
        n = table.shape[1]
        safe = index if mask is None else xp.where(mask, index, xp.zeros_like(index))
        total = None
        for s, w in corners:
            term = w * xp.take(flat, s * n + safe)
            total = term if total is None else total + term
        return total if mask is None else xp.where(mask, total, xp.zeros_like(total))

    def _cell(self, pos: Array) -> tuple[Array, Array, Array, Array]:
        xp = namespace(pos)
        x = xp.clip(pos[..., 0], 0.0, 1.0) * (self.w - 1)
        y = xp.clip(pos[..., 1], 0.0, 1.0) * (self.h - 1)
        ix = xp.clip(xp.astype(xp.floor(x), xp.int64), 0, self.w - 2)
        iy = xp.clip(xp.astype(xp.floor(y), xp.int64), 0, self.h - 2)
        return ix, iy, x - xp.astype(ix, x.dtype), y - xp.astype(iy, y.dtype)

    def eval(self, pos: Array, params: list[Array]) -> Array:
        """The bilinear interpolant at ``pos`` (..., 2) (Mitsuba ``Marginal2D::eval``)."""
        corners = self._corners(params, pos[..., 0])
        ix, iy, x, y = self._cell(pos)
        i = iy * self.w + ix
        v00, v10 = self._lookup(self.data, corners, i), self._lookup(self.data, corners, i + 1)
        v01 = self._lookup(self.data, corners, i + self.w)
        v11 = self._lookup(self.data, corners, i + self.w + 1)
        return (v00 + (v10 - v00) * x) * (1 - y) + (v01 + (v11 - v01) * x) * y

    def invert(self, sample: Array, params: list[Array]) -> Array:
        """The unit-square point that the warp maps to ``sample`` (``invert_continuous``).

        Where the density is zero along the sample's whole row (Mitsuba divides 0 by 0 there)
        the row is inverted as the identity, so the result is always a point of the square.
        """
        xp = namespace(sample)
        corners = self._corners(params, sample[..., 0])
        ix, iy, x, y = self._cell(sample)
        w, h = self.w, self.h
        i = iy * w + ix
        v00, v10 = self._lookup(self.data, corners, i), self._lookup(self.data, corners, i + 1)
        v01, v11 = (
            self._lookup(self.data, corners, i + w),
            self._lookup(self.data, corners, i + w + 1),
        )
        c0, c1 = v00 + (v01 - v00) * y, v10 + (v11 - v10) * y
        sx = x * (c0 + (c1 - c0) * (0.5 * x)) / (w - 1)
        base = iy * (w - 1)
        j = base + ix - 1
        has_left = ix > 0
        left0 = self._lookup(self.cond, corners, j, has_left)
        left1 = self._lookup(self.cond, corners, j + (w - 1), has_left)
        sx = sx + left0 + (left1 - left0) * y
        r0 = self._lookup(self.cond, corners, base + (w - 2))
        r1 = self._lookup(self.cond, corners, base + 2 * (w - 1) - 1)
        row = r0 + (r1 - r0) * y
        has_mass = row > 0  # a row without mass (zero density along it) inverts to identity
        sx = xp.where(
            has_mass, sx / xp.where(has_mass, row, 1.0), xp.clip(sample[..., 0], 0.0, 1.0)
        )
        sy = y * (r0 + (r1 - r0) * (0.5 * y)) / (h - 1)
        sy = sy + self._lookup(self.marg, corners, iy - 1, iy > 0)
        return xp.stack([sx, sy], axis=-1)


# --------------------------------------------------------------------------- checks
_DENSITIES = ("ndf", "sigma", "vndf", "luminance")
"""The 2-D tables (last two axes) that Mitsuba warps or interpolates, besides the colour."""


def _float_fields(colour: str) -> tuple[str, ...]:
    """The float32 fields an RGL file with ``colour`` (``"rgb"`` or ``"spectra"``) needs."""
    spectral = ("wavelengths",) if colour == "spectra" else ()
    return ("theta_i", "phi_i", *_DENSITIES, colour, *spectral)


def _check_fields(f: dict[str, np.ndarray], where: str) -> str:
    """Check the arrays of an RGL file as Mitsuba's ``measured`` plugin does, and their values
    (finite; densities and colours non-negative; angles increasing; ``sigma`` positive where
    the Jacobian divides by it; every ``vndf`` slice non-zero). Returns the colour field,
    ``"rgb"`` or ``"spectra"``.

    Raises
    ------
    FormatError
        Naming ``where`` and the field.
    """
    colour = "rgb" if "rgb" in f else "spectra"
    missing = [k for k in (*_float_fields(colour), "jacobian") if k not in f]
    if missing:
        raise FormatError(where, f"lacks the fields {missing}; it has {sorted(f)}")
    _check_structure(f, where, colour)
    for key in _float_fields(colour):
        _check_values(f[key], where, key, non_negative=key in (*_DENSITIES, colour))
    for key in ("theta_i", "phi_i"):
        if np.any(np.diff(f[key]) <= 0):
            raise FormatError(where, f"must increase strictly; got {f[key]}", field=key)
    if f["jacobian"].ravel()[0] and np.any(f["sigma"] <= 0):
        raise FormatError(where, "the projected area must be positive", field="sigma")
    vndf = f["vndf"]
    if np.any(np.all(vndf.reshape(*vndf.shape[:2], -1) == 0, axis=-1)):
        raise FormatError(
            where, "a slice is zero everywhere: it cannot be normalised", field="vndf"
        )
    if colour == "spectra":
        problem = wavelengths_problem(f["wavelengths"])
        if problem:
            raise FormatError(where, problem, field="wavelengths")
    return colour


def _check_structure(f: dict[str, np.ndarray], where: str, colour: str) -> None:
    """Dtypes and shapes: float32 arrays, a uint8 ``jacobian`` of one entry, ``theta_i`` and
    ``phi_i`` 1-D and non-empty, tables at least 2 × 2, ``vndf``, ``luminance`` and the colour
    on the ``(phi_i, theta_i)`` grid, 3 RGB channels or one per wavelength."""
    for key in _float_fields(colour):
        if f[key].dtype != np.float32:
            raise FormatError(where, f"must be float32; got {f[key].dtype}", field=key)
    jacobian = f["jacobian"]
    if jacobian.dtype != np.uint8 or jacobian.shape != (1,):
        raise FormatError(
            where, f"must be one uint8; got {jacobian.dtype} of shape {jacobian.shape}",
            field="jacobian",
        )  # fmt: skip
    if "description" in f and (f["description"].dtype != np.uint8 or f["description"].ndim != 1):
        raise FormatError(where, "must be a 1-D uint8 array (UTF-8 text)", field="description")
    theta_i, phi_i, data = f["theta_i"], f["phi_i"], f[colour]
    grid = (phi_i.size, theta_i.size)
    channels = 3 if colour == "rgb" else f["wavelengths"].size
    ok = (
        theta_i.ndim == phi_i.ndim == 1
        and theta_i.size >= 1
        and phi_i.size >= 1
        and f["ndf"].ndim == f["sigma"].ndim == 2
        and f["vndf"].ndim == f["luminance"].ndim == 4
        and f["vndf"].shape[:2] == f["luminance"].shape[:2] == grid
        and data.ndim == 5
        and data.shape[:3] == (*grid, channels)
        and f["luminance"].shape[2:] == data.shape[3:]
        and (colour == "rgb" or f["wavelengths"].ndim == 1)
        and min(min(f[k].shape[-2:]) for k in (*_DENSITIES, colour)) >= 2
    )
    if not ok:
        shapes = {k: f[k].shape for k in ("theta_i", "phi_i", *_DENSITIES, colour)}
        raise FormatError(where, f"has an invalid structure: {shapes}")


def _check_values(array: np.ndarray, where: str, key: str, non_negative: bool) -> None:
    """Every entry finite (and ``>= 0`` when ``non_negative``)."""
    bad = ~np.isfinite(array) | ((array < 0) if non_negative else False)
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        kind = "finite and non-negative" if non_negative else "finite"
        raise FormatError(where, f"must be {kind}; entry {index} is {array[index]}", field=key)


# --------------------------------------------------------------------------- the BRDF
def _elevation(d: Array) -> Array:
    """θ = 2 asin(|d − z|/2), Mitsuba's cancellation-free arccos(d.z)."""
    xp = namespace(d)
    dist = xp.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + (d[..., 2] - 1) ** 2)
    return 2 * xp.asin(xp.clip(0.5 * dist, -1.0, 1.0))


def _mirror(v: Array, sx: Array, sy: Array) -> Array:
    """Mitsuba's ``mulsign_neg`` on x and y: negate where the sign source is ≥ 0."""
    xp = namespace(v)
    x = xp.where(sx >= 0, -v[..., 0], v[..., 0])
    y = xp.where(sy >= 0, -v[..., 1], v[..., 1])
    return xp.stack([x, y, v[..., 2]], axis=-1)


@dataclass(frozen=True, eq=False)
class RGLBRDF(CosineSampled):
    r"""A BRDF from the RGL material database, evaluated as Mitsuba 3's ``measured`` plugin.

    See the module docstring for the evaluation. Channels: 3 (linear sRGB) for ``*_rgb`` files
    and for spectral files converted with ``spectral=False``; otherwise one per wavelength
    (``wavelengths``). Not claimed reciprocal or energy-conserving (measured data). Sampled by
    the cosine-weighted hemisphere.

    Parameters
    ----------
    fields : the arrays of the tensor file (:func:`read_tensor_file`).
    spectral : keep spectral channels instead of converting them to sRGB.
    name : a label (the file name), which errors name.

    Raises
    ------
    FormatError
        Naming ``name`` and the field, for missing fields, dtypes or shapes other than
        Mitsuba's, NaN, infinite or negative values, angles that do not increase, a zero
        projected area or ``vndf`` slice, or unusable wavelengths.

    References
    ----------
    .. [1] J. Dupuy, W. Jakob, SIGGRAPH Asia 2018.
    .. [2] Mitsuba 3, ``src/bsdfs/measured.cpp``.
    """

    fields: dict = field(repr=False, default_factory=dict)
    spectral: bool = False
    name: str = ""
    wavelengths: Any = field(init=False, default=None)
    description: str = field(init=False, default="")
    _state: dict = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        f = self.fields
        where = self.name or "RGL fields"
        colour = _check_fields(f, where)
        theta_i, phi_i, data = f["theta_i"], f["phi_i"], f[colour]
        if colour == "spectra":
            wavelengths = np.asarray(f["wavelengths"], dtype=np.float64)
            if not self.spectral:
                matrix = spectrum_to_rgb_matrix(wavelengths).astype(np.float32)
                with np.errstate(over="ignore", invalid="ignore"):  # checked below
                    rgb = np.einsum("pqlhw,lc->pqchw", data.astype(np.float32), matrix)
                data = np.maximum(rgb, 0.0)  # saturated spectra lie outside the sRGB gamut
            else:
                object.__setattr__(self, "wavelengths", wavelengths)
        isotropic = phi_i.size <= 2
        reduction = 0 if isotropic else int(np.rint(2 * math.pi / (phi_i[-1] - phi_i[0])))
        params = [phi_i, theta_i]
        state = {
            "isotropic": isotropic,
            "reduction": reduction,
            "jacobian": bool(f["jacobian"].ravel()[0]),
            "ndf": _Marginal2D(f["ndf"], [], normalize=False, sampling=False),
            "sigma": _Marginal2D(f["sigma"], [], normalize=False, sampling=False),
            "vndf": _Marginal2D(f["vndf"], params, normalize=True, sampling=True),
            "channels": [
                _Marginal2D(data[:, :, c], params, normalize=False, sampling=False)
                for c in range(data.shape[2])
            ],
        }
        vndf = state["vndf"]
        if not all(np.all(np.isfinite(t)) for t in (vndf.data, vndf.cond, vndf.marg)):
            raise FormatError(where, "cannot be normalised in float32 (too small)", field="vndf")
        if not all(np.all(np.isfinite(ch.data)) for ch in state["channels"]):
            raise FormatError(where, "too large to convert to sRGB in float32", field=colour)
        object.__setattr__(self, "_state", state)
        object.__setattr__(self, "channels", data.shape[2])
        if "description" in f:
            text = bytes(f["description"]).decode("utf8", "replace")
            object.__setattr__(self, "description", text)

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self._state["isotropic"]

    def to_spec(self) -> str:
        raise ValueError(
            f"a measured BRDF ({self.name or 'unnamed'}) has no spec string; it is data"
        )

    def __repr__(self) -> str:
        return f"RGLBRDF(name={self.name!r}, channels={self.channels})"

    def eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        wi = asarray(wi, xp)
        wo = asarray(wo, xp, like=wi)
        batch = result_shape(wi, wo)
        light = xp.reshape(xp.broadcast_to(wi, (*batch, 3)), (-1, 3))
        view = xp.reshape(xp.broadcast_to(wo, (*batch, 3)), (-1, 3))
        st = self._state
        active = (light[..., 2] > 0) & (view[..., 2] > 0)
        if st["reduction"] >= 2:
            sy = view[..., 1]
            sx = view[..., 0] if st["reduction"] == 4 else sy
            view, light = _mirror(view, sx, sy), _mirror(light, sx, sy)
        m = view + light
        m = m / xp.sqrt(xp.sum(m * m, axis=-1, keepdims=True))
        theta_i, phi_i = _elevation(view), xp.atan2(view[..., 1], view[..., 0])
        theta_m, phi_m = _elevation(m), xp.atan2(m[..., 1], m[..., 0])
        two_pi = 2 * math.pi
        u_wi = xp.stack([xp.sqrt(theta_i * (2 / math.pi)), (phi_i + math.pi) / two_pi], axis=-1)
        u_phi = ((phi_m - phi_i) if st["isotropic"] else phi_m) + math.pi
        u_phi = u_phi / two_pi
        u_m = xp.stack([xp.sqrt(theta_m * (2 / math.pi)), u_phi - xp.floor(u_phi)], axis=-1)
        params = [phi_i, theta_i]
        s = st["vndf"].invert(u_m, params)
        value = xp.stack([ch.eval(s, params) for ch in st["channels"]], axis=-1)
        if st["jacobian"]:
            ratio = st["ndf"].eval(u_m, []) / (4 * st["sigma"].eval(u_wi, []))
            value = value * ratio[..., None]
        cos_light = xp.where(active, light[..., 2], xp.ones_like(light[..., 2]))
        value = value / cos_light[..., None]
        value = xp.where(active[..., None], value, xp.zeros_like(value))
        return xp.reshape(value, (*batch, self.channels))


def read_rgl(path: str | os.PathLike, *, spectral: bool = False) -> RGLBRDF:
    """Read an RGL ``.bsdf`` file (Dupuy & Jakob 2018) as a :class:`RGLBRDF`.

    Parameters
    ----------
    path : the file.
    spectral : for spectral files, keep one channel per wavelength instead of linear sRGB.

    Raises
    ------
    FormatError
        Naming the file, for a corrupt tensor file (:func:`read_tensor_file`) or fields that are
        not an RGL BRDF (:class:`RGLBRDF`).

    References
    ----------
    .. [1] J. Dupuy, W. Jakob, SIGGRAPH Asia 2018; Mitsuba 3 ``measured`` plugin.
    """
    path = Path(path)
    return RGLBRDF(read_tensor_file(path), spectral=spectral, name=path.name)


__all__ = ["RGLBRDF", "read_rgl", "read_tensor_file"]
