r"""The Hosek–Wilkie (2012) clear sky with a solar disk, as a :class:`~brdfkit.light.Light`.

The sky radiance (RGB) at a direction of zenith angle θ and angle γ from the sun is

.. math::
    L(\theta, \gamma) = \bar L\,\Bigl(1 + A e^{B/(\cos\theta + 0.01)}\Bigr)
        \Bigl(C + D e^{E\gamma} + F\cos^2\gamma + G\,\chi(H, \gamma) + I\sqrt{\cos\theta}\Bigr),
    \qquad \chi(H, \gamma) = \frac{1 + \cos^2\gamma}{(1 + H^2 - 2H\cos\gamma)^{3/2}},

whose nine coefficients A…I and mean radiance :math:`\bar L` per channel are the published
Hosek–Wilkie RGB datasets: interpolated linearly in turbidity T ∈ [1, 10] and ground albedo
(per channel), and along the solar elevation η by the quintic Bézier curve in
:math:`x = (2\eta/\pi)^{1/3}` of the paper. Units and the RGB scale follow Mitsuba 3's
``sunsky`` emitter (``scalar_rgb``): linear sRGB radiance in W·m⁻²·sr⁻¹·nm⁻¹ times Mitsuba's
CIE Y normalisation 1/106.7502593994.

The sun is a disk of half-angle ``sun_aperture``/2 and uniform radiance (Mitsuba's default,
non-"complex" sun): the Hosek–Wilkie (2013) solar irradiance spectrum (Mitsuba's table over 11
wavelengths 320–720 nm, interpolated in T and elevation), projected to linear sRGB as
Mitsuba's RGB mode does (:func:`sun_radiance`), divided by the disk's solid angle.

Importance sampling: the sky by a piecewise-constant table of its luminance over
(φ/2π, 1 − cos θ), texels of equal solid angle on the upper hemisphere (a floor keeps the
density positive wherever the sky shines), the sun by
uniform sampling of its cone; the two mixed in proportion to their power.

References
----------
.. [1] L. Hosek, A. Wilkie, "An analytic model for full spectral sky-dome radiance", ACM TOG
       31(4), 2012.
.. [2] L. Hosek, A. Wilkie, "Adding a solar-radiance function to the Hošek–Wilkie skylight
       model", IEEE CG&A 33(3), 2013.
.. [3] W. Jakob et al., Mitsuba 3, ``src/emitters/sunsky.cpp``, ``include/mitsuba/render/
       sunsky.h``; data ``data/sunsky/*.bin`` (BSD-3, Hosek & Wilkie; see
       ``brdfkit/data/hosek_wilkie_LICENSE.md``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from importlib.resources import files
from typing import Any

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    clamp,
    dot,
    namespace,
    normalize,
    safe_div,
    to_numpy,
)
from brdfkit.data import colorimetry
from brdfkit.errors import ParameterError
from brdfkit.geometry import frame_from_normal, to_world
from brdfkit.light.base import STRENGTH, Light, LightSample, _batch
from brdfkit.params import Domain, channel_count
from brdfkit.sampling import Distribution2D, square_to_uniform_cone, square_to_uniform_cone_pdf

TURBIDITY = Domain(1.0, 10.0, hint="atmospheric turbidity")
"""Linke turbidity T of the Hosek–Wilkie datasets: [1, 10]."""

GROUND_ALBEDO = Domain(0.0, 1.0, hint="ground albedo")

CIE_Y_NORMALIZATION = 1 / 106.7502593994140625
"""Mitsuba 3's ``MI_CIE_Y_NORMALIZATION``, the scale of its RGB sky radiance."""

SPEC_TO_RGB_SUN = 467.069280386
"""Mitsuba 3's ``SPEC_TO_RGB_SUN_CONV``: its factor from the mean over the 11 tabulated
wavelengths of the sRGB-projected solar irradiance to the RGB sun."""

SUN_APERTURE = 0.5358
"""The sun's mean apparent diameter in degrees (Mitsuba's default)."""

_WAVELENGTHS = np.linspace(320.0, 720.0, 11)  # nm, the solar irradiance table's
_BEZIER = (1, 5, 10, 10, 5, 1)


@functools.lru_cache(maxsize=1)
def _datasets() -> dict[str, np.ndarray]:
    path = files("brdfkit.data") / "hosek_wilkie_rgb.npz"
    with np.load(str(path)) as data:
        return {name: np.asarray(data[name], dtype=np.float64) for name in data.files}


def _lerp_index(table: np.ndarray, index: float) -> np.ndarray:
    """``table`` interpolated linearly along its first axis at fractional ``index``."""
    index = min(max(index, 0.0), table.shape[0] - 1.0)
    low = min(math.floor(index), table.shape[0] - 2)
    w = index - low
    return (1 - w) * table[low] + w * table[low + 1]


def sky_coefficients(
    turbidity: float, albedo: np.ndarray, elevation: float
) -> tuple[np.ndarray, np.ndarray]:
    """The Hosek–Wilkie RGB coefficients ``(params (3, 9), mean radiance (3,))`` for a
    turbidity, per-channel ground ``albedo`` (3,) and solar elevation (radians)."""
    data = _datasets()
    out = []
    for name in ("sky_params", "sky_radiance"):
        table = _lerp_index(data[name], turbidity - 1)  # (albedo, bezier, channel[, param])
        a = albedo.reshape((1, 3) + (1,) * (table.ndim - 3))
        table = (1 - a) * table[0] + a * table[1]  # (bezier, channel[, param])
        x = min(math.cbrt(2 * max(elevation, 0.0) / math.pi), 1 - 1e-7)
        weights = [c * x**k * (1 - x) ** (5 - k) for k, c in enumerate(_BEZIER)]
        out.append(sum(w * table[k] for k, w in enumerate(weights)))
    return out[0], out[1]


def hosek_wilkie_radiance(
    cos_theta: Array, gamma: Array, params: np.ndarray, radiance: np.ndarray
) -> Array:
    r"""The sky radiance formula of the module docstring, ``(..., 3)``, for ``cos_theta`` and
    ``gamma`` of shape ``(..., 1)`` (no horizon test, no scale)."""
    xp = namespace(cos_theta, gamma)
    p = [asarray(params[:, k], xp, like=cos_theta, dtype=cos_theta.dtype) for k in range(9)]
    mean = asarray(radiance, xp, like=cos_theta, dtype=cos_theta.dtype)
    cos_gamma = xp.cos(gamma)
    cos_gamma2 = cos_gamma * cos_gamma
    c1 = 1 + p[0] * xp.exp(p[1] / (cos_theta + 0.01))
    chi = (1 + cos_gamma2) / (1 + p[8] * p[8] - 2 * p[8] * cos_gamma) ** 1.5
    root = xp.sqrt(xp.maximum(cos_theta, xp.zeros_like(cos_theta)))
    c2 = p[2] + p[3] * xp.exp(p[4] * gamma) + p[5] * cos_gamma2 + p[6] * chi + p[7] * root
    return c1 * c2 * mean


def sun_radiance(turbidity: float, elevation: float, aperture: float = SUN_APERTURE) -> np.ndarray:
    r"""Linear sRGB radiance (Mitsuba's scale) of the uniform solar disk of diameter ``aperture``
    degrees, whose irradiance is the same for every aperture.

    Mitsuba 3's RGB recipe: the solar irradiance spectrum :math:`E(\lambda_k)` at its 11
    wavelengths (interpolated in turbidity and in elevation, tabulated every 3° from 2°),
    projected to sRGB with the CIE 1931 functions at those wavelengths,
    :math:`\mathrm{RGB} = M_{sRGB}\,\mathrm{mean}_k(\bar{\mathbf x}(\lambda_k)E(\lambda_k))
    \cdot 467.07 \cdot (1/106.75) / \Omega_{sun}` (``SPEC_TO_RGB_SUN_CONV``,
    ``MI_CIE_Y_NORMALIZATION``). The CIE table and the sRGB matrix are
    :mod:`brdfkit.data.colorimetry`'s (colour-science's values, shipped rather than imported:
    a 94 MiB install for a table and a matrix).
    """
    table = _lerp_index(_datasets()["sun_irradiance"], turbidity - 1)  # (elevation, λ)
    index = (math.degrees(elevation) - 2.0) / 3.0
    irradiance = _lerp_index(table, min(max(index, 0.0), table.shape[0] - 1 - 1e-7))
    xyz = np.mean(colorimetry.observer_at(_WAVELENGTHS) * irradiance[:, None], axis=0)
    rgb = colorimetry.XYZ_TO_LINEAR_SRGB @ xyz
    solid_angle = 2 * math.pi * (1 - math.cos(math.radians(aperture / 2)))
    return np.asarray(rgb, dtype=np.float64) * SPEC_TO_RGB_SUN * CIE_Y_NORMALIZATION / solid_angle


@dataclass(frozen=True, eq=False)
class SunSky(Light):
    """The Hosek–Wilkie sky and the sun (module docstring), world +z up.

    Parameters
    ----------
    sun_direction : direction towards the sun (world; normalised), above the horizon.
    turbidity : T ∈ [1, 10] (default 3: a clear temperate sky).
    albedo : ground albedo ∈ [0, 1], scalar or RGB (default 0.3).
    sky_scale, sun_scale : factors on the sky's and the sun's radiance (default 1; 0 turns one
        off).
    sun_aperture : the sun's apparent diameter in degrees, in (0, 10] (default 0.5358).
    resolution : ``(rows, columns)`` of the sky's sampling table over the upper hemisphere.

    Examples
    --------
    A clear sky with the sun at 53° elevation: the zenith is blue, the ground dark, the sun
    brighter than the sky by orders of magnitude:

    >>> import numpy as np
    >>> sky = SunSky(sun_direction=(0.0, 0.6, 0.8), turbidity=3.0, resolution=(8, 16))
    >>> zenith = sky.sky_radiance(np.array([0.0, 0.0, 1.0]))
    >>> zenith.round(4).tolist(), bool(zenith[2] > zenith[0])
    ([0.0291, 0.0482, 0.0956], True)
    >>> sky.incident_radiance(np.zeros(3), np.array([0.0, 0.0, -1.0])).tolist()
    [0.0, 0.0, 0.0]
    >>> bool(sky.incident_radiance(np.zeros(3), sky.sun_direction)[1] > 1e4)
    True

    Samples pick the sun or the sky in proportion to their power; value · pdf is the radiance:

    >>> sample = sky.sample(np.zeros((2, 3)), np.array([[0.1, 0.2], [0.9, 0.7]]))
    >>> radiance = sky.incident_radiance(np.zeros((2, 3)), sample.wi)
    >>> bool(np.allclose(sample.value * sample.pdf[:, None], radiance))
    True
    """

    sun_direction: Any = (0.0, 0.6, 0.8)
    turbidity: float = 3.0
    albedo: Any = 0.3
    sky_scale: float = 1.0
    sun_scale: float = 1.0
    sun_aperture: float = SUN_APERTURE
    resolution: tuple[int, int] = (64, 256)

    def __post_init__(self) -> None:
        sun = np.asarray(to_numpy(self.sun_direction), dtype=np.float64)
        if sun.shape != (3,) or not np.all(np.isfinite(sun)) or np.linalg.norm(sun) == 0:
            raise ParameterError(f"sun_direction must be a non-zero 3-vector; got {sun!r}")
        sun = sun / np.linalg.norm(sun)
        if sun[2] <= 0:
            raise ParameterError(f"sun_direction must point above the horizon; got z = {sun[2]}")
        TURBIDITY.check("turbidity", self.turbidity)
        GROUND_ALBEDO.check("albedo", self.albedo)
        channel_count(self.albedo, np.zeros(3), names=("albedo", "RGB"))
        STRENGTH.check("sky_scale", self.sky_scale)
        STRENGTH.check("sun_scale", self.sun_scale)
        Domain(0.0, 10.0, lo_open=True, hint="degrees").check("sun_aperture", self.sun_aperture)
        rows, cols = (int(n) for n in self.resolution)
        if rows < 2 or cols < 2:
            raise ParameterError(f"resolution must be two sizes ≥ 2; got {self.resolution!r}")
        albedo = np.broadcast_to(np.asarray(to_numpy(self.albedo), dtype=np.float64), (3,))
        elevation = math.pi / 2 - math.acos(min(sun[2], 1.0))
        params, radiance = sky_coefficients(float(self.turbidity), albedo, elevation)
        object.__setattr__(self, "sun_direction", sun)
        object.__setattr__(self, "channels", 3)
        object.__setattr__(self, "_params", params)
        object.__setattr__(self, "_radiance", radiance)
        sun_rgb = sun_radiance(float(self.turbidity), elevation, float(self.sun_aperture))
        object.__setattr__(self, "_sun", sun_rgb * float(self.sun_scale))
        object.__setattr__(self, "_cos_sun", math.cos(math.radians(self.sun_aperture / 2)))
        self._build_sampling(rows, cols)

    def _build_sampling(self, rows: int, cols: int) -> None:
        """The sky's sampling table over (φ/2π, 1 − cos θ), texels of equal solid angle
        (luminance at texel centres, 3×3 maxima, a floor), and the sun's share of the power."""
        from scipy.ndimage import maximum_filter

        cos_theta = 1 - (np.arange(rows) + 0.5) / rows
        phi = (np.arange(cols) + 0.5) / cols * (2 * math.pi)
        c, p = np.meshgrid(cos_theta, phi, indexing="ij")
        s = np.sqrt(1 - c * c)
        wi = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1)
        lum = self.sky_radiance(wi) @ np.array([0.2126, 0.7152, 0.0722])
        sky_power = float(np.mean(np.maximum(lum, 0.0)) * 2 * math.pi)
        lum = maximum_filter(np.maximum(lum, 0.0), size=3, mode=("nearest", "wrap"))
        weights = lum + 1e-2 * max(lum.mean(), 1e-30)
        sun_power = float(self._sun @ np.array([0.2126, 0.7152, 0.0722])) * (
            2 * math.pi * (1 - self._cos_sun)
        )
        total = sky_power + sun_power
        object.__setattr__(self, "_distribution", Distribution2D(weights))
        object.__setattr__(self, "_p_sun", sun_power / total if total > 0 else 0.0)

    # -- radiance ------------------------------------------------------------------------------
    def sky_radiance(self, wi: Array) -> Array:
        """The sky's radiance towards unit ``wi`` (no sun), ``(..., 3)``; 0 below the horizon."""
        xp = namespace(wi)
        sun = asarray(self.sun_direction, xp, like=wi, dtype=wi.dtype)
        gamma = xp.acos(clamp(dot(wi, sun, keepdims=True), -1.0, 1.0))
        cos_theta = clamp(wi[..., 2:3], 0.0, 1.0)
        value = hosek_wilkie_radiance(cos_theta, gamma, self._params, self._radiance)
        value = value * (CIE_Y_NORMALIZATION * float(self.sky_scale))
        return xp.where(wi[..., 2:3] >= 0, value, xp.zeros_like(value))

    def _in_sun(self, wi: Array) -> Array:
        xp = namespace(wi)
        sun = asarray(self.sun_direction, xp, like=wi, dtype=wi.dtype)
        return (dot(wi, sun, keepdims=True) >= self._cos_sun) & (wi[..., 2:3] >= 0)

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        wi = normalize(wi)
        sun = asarray(self._sun, xp, like=wi, dtype=wi.dtype)
        value = self.sky_radiance(wi) + xp.where(self._in_sun(wi), sun, xp.zeros_like(sun))
        return xp.broadcast_to(value, (*_batch(points, wi), 3))

    # -- sampling ------------------------------------------------------------------------------
    def _sky_pdf(self, wi: Array) -> Array:
        xp = namespace(wi)
        phi = xp.remainder(xp.atan2(wi[..., 1], wi[..., 0]), 2 * math.pi)
        uv = xp.stack([phi / (2 * math.pi), 1 - wi[..., 2]], axis=-1)
        upper = wi[..., 2] > 0
        uv = xp.where(upper[..., None], clamp(uv, 0.0, 1 - 1e-12), xp.zeros_like(uv))
        pdf = self._distribution.pdf(uv) / (2 * math.pi)  # dω = 2π du dv
        return xp.where(upper, pdf, xp.zeros_like(pdf))

    def _sun_pdf(self, wi: Array) -> Array:
        xp = namespace(wi)
        frame = frame_from_normal(asarray(self.sun_direction, xp, like=wi, dtype=wi.dtype))
        local = xp.stack([dot(wi, axis) for axis in frame], axis=-1)
        return square_to_uniform_cone_pdf(local, self._cos_sun) * xp.astype(
            self._in_sun(wi)[..., 0], wi.dtype
        )

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        wi = normalize(wi)
        value = self._p_sun * self._sun_pdf(wi) + (1 - self._p_sun) * self._sky_pdf(wi)
        return xp.broadcast_to(value, _batch(points, wi))

    def sample(self, points: Array, u: Array) -> LightSample:
        xp = namespace(points, u)
        u = asarray(u[..., :2], xp, like=points)
        p_sun = self._p_sun
        pick_sun = u[..., 0] < p_sun
        u0 = xp.where(
            pick_sun,
            u[..., 0] / max(p_sun, 1e-300),
            (u[..., 0] - p_sun) / max(1 - p_sun, 1e-300),
        )
        u = xp.stack([clamp(u0, 0.0, 1 - 1e-12), u[..., 1]], axis=-1)
        frame = frame_from_normal(asarray(self.sun_direction, xp, like=points))
        wi_sun = to_world(square_to_uniform_cone(u, self._cos_sun), frame)
        uv, _ = self._distribution.sample(u)
        cos_theta, phi = 1 - uv[..., 1], uv[..., 0] * (2 * math.pi)
        sin_theta = xp.sqrt(xp.maximum(1 - cos_theta * cos_theta, xp.zeros_like(cos_theta)))
        wi_sky = xp.stack([sin_theta * xp.cos(phi), sin_theta * xp.sin(phi), cos_theta], -1)
        wi = normalize(xp.where(pick_sun[..., None], wi_sun, wi_sky))
        pdf = self.pdf(points, wi)
        radiance = self.incident_radiance(points, wi)
        value = xp.where((pdf > 0)[..., None], safe_div(radiance, pdf[..., None]), 0 * radiance)
        batch = _batch(points, wi)
        return LightSample(
            xp.broadcast_to(wi, (*batch, 3)),
            value,
            pdf,
            xp.full(batch, math.inf, dtype=points.dtype),
            False,
        )


__all__ = [
    "CIE_Y_NORMALIZATION",
    "SUN_APERTURE",
    "TURBIDITY",
    "SunSky",
    "hosek_wilkie_radiance",
    "sky_coefficients",
    "sun_radiance",
]
