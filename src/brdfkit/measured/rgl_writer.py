r"""Write any BRDF, measured or analytic, as an RGL ``.bsdf`` tensor file (Dupuy & Jakob 2018).

The inverse of :mod:`brdfkit.measured.rgl`, in the layout that module reads and Mitsuba 3's
``measured`` plugin loads (the fields ``description``, ``theta_i``, ``phi_i``, ``ndf``,
``sigma``, ``vndf``, ``luminance``, ``rgb``, ``jacobian``). With ω the viewing direction
(brdfkit's ``wo``, Mitsuba's ``si.wi``), :math:`u(\theta, \varphi) = (\sqrt{2\theta/\pi},
(\varphi + \pi)/2\pi)` the unit-square coordinates of a direction, and the half vector
:math:`\omega_m` measured from :math:`\varphi_i` for isotropic data:

1. ``ndf`` — a microfacet distribution :math:`D` on the :math:`u_m` square, estimated from the
   retro-reflection :math:`D(\omega) \propto Y(f(\omega, \omega))\cos^2\theta` (the luminance
   of the BRDF's back-scatter; exact up to :math:`F G` for a microfacet model), floored at
   10⁻³ of its maximum and normalised to :math:`\int D\cos\theta_m\,d\omega_m = 1`;
2. ``sigma`` — its projected area :math:`\sigma(\omega) = \int D(\omega_m)\langle\omega\cdot
   \omega_m\rangle d\omega_m` (quadrature);
3. ``vndf`` — per incident node, the visible normals :math:`D(\omega_m)\langle\omega\cdot
   \omega_m\rangle/\sigma(\omega)` as a density on the :math:`u_m` square (times
   :math:`|\partial\omega_m/\partial u_m| = 2\pi^2 u_{m,0}\sin\theta_m`): the warp whose
   inverse maps a half vector to the sample square :math:`s`;
4. ``rgb`` — on a regular grid of :math:`s`, at :math:`u_m = \mathrm{VNDF}(s)` (the warp run
   forward by bisection on Mitsuba's own inverse, so that a lookup at a node returns the node),
   :math:`f(\omega_o, \omega)\cos\theta_o \cdot 4\sigma(\omega)/D(\omega_m)` with
   :math:`\omega_o = 2(\omega\cdot\omega_m)\omega_m - \omega` (``jacobian`` = 1: the reader
   multiplies by :math:`D/4\sigma` again, with the same interpolants);
5. ``luminance`` — the luminance of ``rgb``, the density Mitsuba samples :math:`s` from
   (floored at 10⁻³ of each slice's maximum so that no slice is empty).

Accuracy: exact at the nodes; between them, the bilinear interpolation of the tables. On
uniform random direction pairs (``benchmarks/bench_export.py``), GGX α = 0.3 gold at the
default 64² sample square is within 0.1 % of the model (median; 90th percentile 7 %, in the
faint tails far from the peak, where the warp puts few samples); anisotropic GGX
(α = 0.1, 0.3) at 32² within 0.6 % (median), as Mitsuba's ``measured`` plugin reads the file.
An anisotropic model takes a minute and 20 MB (``phi_nodes`` incident azimuths). Only
reflection is tabulated: delta lobes and transmission have no place in the format. One channel
is written as grey RGB; other channel counts than 1 and 3 are refused.

References
----------
.. [1] J. Dupuy, W. Jakob, "An adaptive parameterization for efficient material acquisition
       and rendering", ACM TOG 37(6) (SIGGRAPH Asia), 2018.
.. [2] W. Jakob et al., Mitsuba 3: ``src/bsdfs/measured.cpp``, ``include/mitsuba/core/
       distr_2d.h`` (``Marginal2D``), ``python/tensor_io.py``.

Examples
--------
>>> import tempfile
>>> from pathlib import Path
>>> import numpy as np
>>> from brdfkit.brdf import RoughConductor
>>> from brdfkit.measured import read_rgl
>>> gold = RoughConductor(alpha=0.3, material="Au")
>>> with tempfile.TemporaryDirectory() as folder:
...     path = write_rgl(gold, Path(folder) / "gold.bsdf", theta_nodes=6, resolution=16)
...     table = read_rgl(path)
>>> wi, wo = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0])
>>> bool(np.allclose(table.eval(wi, wo), gold.eval(wi, wo), rtol=1e-3))
True
"""

from __future__ import annotations

import math
import os
import struct
from pathlib import Path

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.errors import ParameterError
from brdfkit.io import REC709_WEIGHTS, atomic_write
from brdfkit.measured.rgl import _DTYPES, _MAGIC, _Marginal2D

_CODES = {np.dtype(dtype): code for code, dtype in _DTYPES.items()}
FLOOR = 1e-3
"""Fraction of the maximum below which ``ndf`` and ``luminance`` are raised (no empty cells)."""
THETA_MAX = math.radians(89.0)
"""The last incident elevation tabulated (at 90° a one-sided BRDF is 0)."""


def write_tensor_file(path: str | os.PathLike, fields: dict[str, np.ndarray]) -> Path:
    """Write named arrays as a Mitsuba tensor file (the layout of
    :func:`~brdfkit.measured.read_tensor_file`), atomically; returns the path.

    Each array's data start at a multiple of 8 bytes, little-endian, C-order.

    Raises
    ------
    brdfkit.errors.ParameterError
        For an array whose dtype the format has no code for.
    """
    arrays = {name: np.ascontiguousarray(value) for name, value in fields.items()}
    for name, array in arrays.items():
        if array.dtype.newbyteorder("=") not in _CODES:
            raise ParameterError(f"field {name!r} has dtype {array.dtype}, not a tensor type")
    header_size = 18 + sum(2 + len(n.encode()) + 11 + 8 * a.ndim for n, a in arrays.items())
    header, blobs, offset = [_MAGIC, struct.pack("<BBI", 1, 0, len(arrays))], [], header_size
    for name, array in arrays.items():
        offset += -offset % 8
        encoded = name.encode("utf8")
        code = _CODES[array.dtype.newbyteorder("=")]
        fixed = struct.pack(
            f"<H{len(encoded)}sHBQ", len(encoded), encoded, array.ndim, code, offset
        )
        header.append(fixed)
        header.append(struct.pack(f"<{array.ndim}Q", *array.shape))
        little = array.astype(array.dtype.newbyteorder("<"), copy=False).tobytes()
        blobs.append((offset, little))
        offset += len(little)
    data = bytearray(offset)
    head = b"".join(header)
    data[: len(head)] = head
    for start, blob in blobs:
        data[start : start + len(blob)] = blob
    return atomic_write(path, lambda tmp: tmp.write_bytes(bytes(data)))


def write_rgl(
    brdf: BRDF,
    path: str | os.PathLike,
    *,
    theta_nodes: int = 16,
    phi_nodes: int = 16,
    resolution: int = 64,
    ndf_resolution: int = 128,
    description: str = "",
) -> Path:
    """Tabulate ``brdf`` (module docstring) and write it as an RGL ``.bsdf`` file; the path.

    Parameters
    ----------
    brdf : any one-sided BRDF with 1 or 3 channels (an anisotropic one gets ``phi_nodes``
        incident azimuths over the full circle).
    path : the file, written atomically.
    theta_nodes, phi_nodes : incident elevations (0 to 89°) and azimuths (anisotropic only).
    resolution : the side of the ``rgb``/``luminance`` sample square.
    ndf_resolution : the side of the ``ndf``, ``sigma`` and ``vndf`` tables.
    description : the file's text field (UTF-8).

    Raises
    ------
    brdfkit.errors.ParameterError
        For another channel count, or a resolution below 2.
    """
    fields = rgl_fields(
        brdf,
        theta_nodes=theta_nodes,
        phi_nodes=phi_nodes,
        resolution=resolution,
        ndf_resolution=ndf_resolution,
        description=description,
    )
    return write_tensor_file(path, fields)


def rgl_fields(
    brdf: BRDF,
    *,
    theta_nodes: int = 16,
    phi_nodes: int = 16,
    resolution: int = 64,
    ndf_resolution: int = 128,
    description: str = "",
) -> dict[str, np.ndarray]:
    """The arrays of :func:`write_rgl`'s file (``read_tensor_file``'s layout)."""
    if brdf.channels not in (1, 3):
        raise ParameterError(
            f"an RGL file holds RGB; the BRDF has {brdf.channels} channels (1 or 3 expected)"
        )
    sizes = {"theta_nodes": theta_nodes, "phi_nodes": phi_nodes, "resolution": resolution}
    for name, value in {**sizes, "ndf_resolution": ndf_resolution}.items():
        if int(value) < 2:
            raise ParameterError(f"{name} must be at least 2; got {value!r}")
    isotropic = brdf.isotropic
    theta_i = np.linspace(0.0, THETA_MAX, theta_nodes)
    phi_i = np.zeros(1) if isotropic else np.linspace(-math.pi, math.pi, phi_nodes)
    ndf = _ndf_table(brdf, ndf_resolution, isotropic)
    sigma = _sigma_table(ndf, isotropic)
    vndf = _vndf_table(ndf, sigma, phi_i, theta_i, isotropic)
    rgb = _rgb_table(brdf, ndf, sigma, vndf, phi_i, theta_i, resolution, isotropic)
    luminance = np.einsum("pqchw,c->pqhw", rgb, np.asarray(REC709_WEIGHTS, dtype=np.float64))
    peak = luminance.max(axis=(-2, -1), keepdims=True)
    luminance = np.maximum(luminance, FLOOR * peak + np.finfo(np.float32).tiny)
    f32 = np.float32
    return {
        "description": np.frombuffer(description.encode("utf8"), dtype=np.uint8).copy(),
        "theta_i": theta_i.astype(f32),
        "phi_i": phi_i.astype(f32),
        "ndf": ndf.astype(f32),
        "sigma": sigma.astype(f32),
        "vndf": vndf.astype(f32),
        "luminance": luminance.astype(f32),
        "rgb": rgb.astype(f32),
        "jacobian": np.ones(1, dtype=np.uint8),
    }


# --------------------------------------------------------------------------- unit square
def _directions(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    st = np.sin(theta)
    return np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), np.cos(theta)), -1)


def _square(rows: int, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """The nodes ``(u0, u1)`` of a ``rows × columns`` table (u0 along the columns)."""
    u1, u0 = np.meshgrid(np.linspace(0, 1, rows), np.linspace(0, 1, columns), indexing="ij")
    return u0, u1


def _u_to_angles(u0: np.ndarray, u1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mitsuba's ``u2theta``, ``u2phi``: θ = u0²π/2, φ = (2 u1 − 1)π."""
    return u0 * u0 * (math.pi / 2), (2 * u1 - 1) * math.pi


def _jacobian(u0: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """|dω/du| = 2π² u0 sin θ."""
    return 2 * math.pi**2 * u0 * np.sin(theta)


def _grey(values: np.ndarray) -> np.ndarray:
    """Luminance of (…, 3) values, or the one channel."""
    if values.shape[-1] == 3:
        return values @ np.asarray(REC709_WEIGHTS, dtype=np.float64)
    return values[..., 0]


# --------------------------------------------------------------------------- tables
def _ndf_table(brdf: BRDF, n: int, isotropic: bool) -> np.ndarray:
    """``ndf`` (rows φ_m, columns θ_m): the retro-reflection estimate, normalised."""
    u0, u1 = _square(2 if isotropic else n, n)
    theta, phi = _u_to_angles(u0, u1)
    m = _directions(theta, phi)
    raw = _grey(np.asarray(brdf.eval(m, m), dtype=np.float64)) * np.cos(theta) ** 2
    raw = np.where(np.isfinite(raw), raw, 0.0)
    if raw.max() <= 0:  # no back-scatter at all: a cosine lobe
        raw = np.cos(theta)
    d = np.maximum(raw, FLOOR * raw.max())
    weight = np.cos(theta) * _jacobian(u0, theta)
    return d / np.trapezoid(np.trapezoid(d * weight, u0, axis=1), u1[:, 0])


def _sigma_table(ndf: np.ndarray, isotropic: bool) -> np.ndarray:
    """``sigma`` on the table's nodes, σ(ω) = ∫ D⟨ω·m⟩ dm, by the midpoint rule over
    the bilinear ``ndf``."""
    table = _Marginal2D(ndf, [], normalize=False, sampling=False)
    q = 2 * ndf.shape[1]
    mid = (np.arange(q) + 0.5) / q
    mu1, mu0 = np.meshgrid(mid, mid, indexing="ij")
    theta_m, phi_m = _u_to_angles(mu0, mu1)
    m = _directions(theta_m, phi_m).reshape(-1, 3)
    d = table.eval(np.stack([mu0, mu1], -1), []).reshape(-1)
    weight = d * _jacobian(mu0, theta_m).reshape(-1) / (q * q)
    u0, u1 = _square(*ndf.shape)
    theta, phi = _u_to_angles(u0, u1)
    w = _directions(theta, phi).reshape(-1, 3)
    sigma = np.concatenate(
        [np.maximum(chunk @ m.T, 0.0) @ weight for chunk in np.array_split(w, max(1, len(w) // 64))]
    )
    return sigma.reshape(ndf.shape)


def _vndf_table(ndf, sigma, phi_i, theta_i, isotropic: bool) -> np.ndarray:
    """``vndf`` (φi, θi, rows φ_m, columns θ_m): D⟨ω·m⟩/σ(ω) · |dω_m/du_m|."""
    d_table = _Marginal2D(ndf, [], normalize=False, sampling=False)
    s_table = _Marginal2D(sigma, [], normalize=False, sampling=False)
    n = ndf.shape[1]
    u0, u1 = _square(n, n)
    d = d_table.eval(np.stack([u0, u1], -1), [])
    theta_m, phi_rel = _u_to_angles(u0, u1)
    out = np.empty((phi_i.size, theta_i.size, n, n))
    for p, phi in enumerate(phi_i):
        for t, theta in enumerate(theta_i):
            view = _directions(np.array(theta), np.array(phi))
            m = _directions(theta_m, phi_rel + (phi if isotropic else 0.0))
            visible = np.maximum(m @ view, 0.0)
            u_view = np.array([math.sqrt(theta * 2 / math.pi), (phi + math.pi) / (2 * math.pi)])
            area = s_table.eval(u_view, [])
            out[p, t] = d * visible / area * _jacobian(u0, theta_m)
    return out


def _forward_warp(warp: _Marginal2D, s: np.ndarray, params: list[np.ndarray]) -> np.ndarray:
    """The half-vector square points ``u_m`` whose inverse warp is ``s`` (bisection on
    Mitsuba's ``invert``: its second coordinate depends on ``u_m``'s second alone, its first
    increases with the first); float32 tables need 26 halvings."""
    lo, hi = np.zeros(s.shape[:-1]), np.ones(s.shape[:-1])
    for _ in range(26):
        mid = 0.5 * (lo + hi)
        probe = np.stack([np.full_like(mid, 0.5), mid], -1)
        below = warp.invert(probe, params)[..., 1] < s[..., 1]
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    y = 0.5 * (lo + hi)
    lo, hi = np.zeros_like(y), np.ones_like(y)
    for _ in range(26):
        mid = 0.5 * (lo + hi)
        below = warp.invert(np.stack([mid, y], -1), params)[..., 0] < s[..., 0]
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return np.stack([0.5 * (lo + hi), y], -1)


def _rgb_table(brdf, ndf, sigma, vndf, phi_i, theta_i, resolution, isotropic) -> np.ndarray:
    """``rgb`` (φi, θi, 3, rows, columns) on the sample square: f cos θo · 4σ/D. At a node
    (φi, θi), Mitsuba's interpolated warp is that node's slice, normalised alone: the slices
    are warped together, indexed by an integer parameter."""
    d_table = _Marginal2D(ndf, [], normalize=False, sampling=False)
    s_table = _Marginal2D(sigma, [], normalize=False, sampling=False)
    slices = vndf.reshape(-1, *vndf.shape[2:])
    index = np.arange(len(slices), dtype=np.float64)
    warp = _Marginal2D(slices, [index], normalize=True, sampling=True)
    s0, s1 = _square(resolution, resolution)
    grid = np.broadcast_to(np.stack([s0, s1], -1), (len(slices), *s0.shape, 2))
    which = np.broadcast_to(index[:, None, None], grid.shape[:-1])
    u_m = _forward_warp(warp, grid, [which]).reshape(*vndf.shape[:2], *s0.shape, 2)
    phi = np.broadcast_to(phi_i[:, None, None, None], u_m.shape[:-1])
    theta = np.broadcast_to(theta_i[None, :, None, None], u_m.shape[:-1])
    theta_m, phi_m = _u_to_angles(u_m[..., 0], u_m[..., 1])
    m = _directions(theta_m, phi_m + (phi if isotropic else 0.0))
    view = _directions(theta, phi)
    light = 2 * np.sum(view * m, axis=-1, keepdims=True) * m - view
    u_view = np.stack([np.sqrt(theta * 2 / math.pi), (phi + math.pi) / (2 * math.pi)], -1)
    ratio = 4 * s_table.eval(u_view, []) / d_table.eval(u_m, [])
    f = np.asarray(brdf.eval(light, view), dtype=np.float64)
    value = f * (np.maximum(light[..., 2], 0.0) * ratio)[..., None]
    value = np.where(np.isfinite(value) & (value > 0), value, 0.0)
    value = np.broadcast_to(value, (*value.shape[:-1], 3))
    return np.moveaxis(value, -1, 2)


__all__ = ["FLOOR", "THETA_MAX", "rgl_fields", "write_rgl", "write_tensor_file"]
