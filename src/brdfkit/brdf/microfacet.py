r"""Microfacet building blocks: normal distributions, masking–shadowing, Fresnel terms.

A microfacet surface is a random height field whose facets are ideal mirrors. Its reflectance
is assembled from three reusable parts, each defined in the local frame (z the normal):

- a normal distribution :math:`D(\omega_m)` (:class:`Beckmann`, :class:`GGX` — both
  anisotropic with roughness :math:`\alpha_x, \alpha_y` along the tangent x and bitangent y —
  and the Torrance–Sparrow Gaussian :class:`TorranceSparrowGaussian`), normalised so that the
  projected microfacet area equals the macro-surface area,
  :math:`\int_{\Omega} D(\omega_m)\cos\theta_m\,d\omega_m = 1`;
- Smith's :math:`\Lambda(\omega)` and masking :math:`G_1(\omega,\omega_m)=\chi^+(\omega\cdot
  \omega_m)/(1+\Lambda(\omega))`, which satisfy the weak white-furnace identity
  :math:`\int G_1(\omega_o,\omega_m) D(\omega_m)\langle\omega_o\cdot\omega_m\rangle d\omega_m
  = \cos\theta_o`, and the joint masking–shadowing :func:`masking_shadowing`
  (``"v_groove"``, ``"smith_separable"``, ``"smith_correlated"``);
- a Fresnel factor :class:`FresnelTerm` (exact dielectric or conductor, Schlick, or none).

Every distribution samples :math:`D\cos\theta_m` (:meth:`MicrofacetDistribution.sample`);
Beckmann and GGX also sample the distribution of normals visible from a direction,
:math:`D_\omega(\omega_m) = G_1(\omega,\omega_m)\langle\omega\cdot\omega_m\rangle
D(\omega_m)/\cos\theta` (``sample_visible``; Heitz 2018 for GGX, Jakob 2014 for Beckmann).

Parameters broadcast against ``batch + (C,)``: ``D`` and ``Λ`` are per channel, shape
``(..., C)``. Samplers use one roughness per batch element, the mean over channels of a
channel-varying roughness (the densities they report use the same mean), so that one sampled
normal serves all channels.

References
----------
.. [1] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
       through rough surfaces", EGSR 2007.
.. [2] E. Heitz, "Understanding the masking-shadowing function in microfacet-based BRDFs",
       JCGT 3(2), 2014.
.. [3] E. Heitz, "Sampling the GGX distribution of visible normals", JCGT 7(4), 2018.
.. [4] E. Heitz, E. d'Eon, "Importance sampling microfacet-based BSDFs using the distribution
       of visible normals", EGSR 2014.
.. [5] W. Jakob, "An improved visible normal sampling routine for the Beckmann distribution",
       technical note, 2014; Mitsuba 3 ``include/mitsuba/render/microfacet.h``.
.. [6] K. E. Torrance, E. M. Sparrow, "Theory for off-specular reflection from roughened
       surfaces", JOSA 57(9), 1967.
.. [7] R. L. Cook, K. E. Torrance, "A reflectance model for computer graphics", ACM TOG 1(1),
       1982.
.. [8] P. Beckmann, A. Spizzichino, *The Scattering of Electromagnetic Waves from Rough
       Surfaces*, Pergamon, 1963.
.. [9] T. S. Trowbridge, K. P. Reitz, "Average irregularity representation of a rough surface
       for ray reflection", JOSA 65(5), 1975.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    channels_first,
    channels_last,
    clamp,
    constant,
    cross,
    dot,
    erf,
    erfinv,
    is_numpy,
    log_gamma,
    namespace,
    normalize,
    safe_div,
    safe_sqrt,
    to_numpy,
)
from brdfkit.brdf.base import ALBEDO, ROUGHNESS, per_direction
from brdfkit.errors import ParameterError
from brdfkit.fresnel import CONDUCTORS, conductor, fresnel_conductor, fresnel_dielectric, schlick
from brdfkit.params import Domain, channel_count, check_choice, check_flag, param

MASKINGS = ("v_groove", "smith_separable", "smith_correlated")
"""The masking–shadowing functions :func:`masking_shadowing` knows."""

FRESNELS = ("none", "dielectric", "conductor", "schlick")
"""The Fresnel factors :class:`FresnelTerm` knows."""

GAUSSIAN_WIDTH = Domain(1e-4, 10.0, hint="angular roughness in radians", log=True)
"""The width m of the Torrance–Sparrow Gaussian: [10⁻⁴, 10] radians (beyond π/2 it is nearly
uniform)."""

IOR = Domain(0.01, 100.0, hint="relative index of refraction")
"""A relative index of refraction η (dielectric, or the real part of a conductor's): [0.01, 100]."""

EXTINCTION = Domain(0.0, 100.0, hint="extinction coefficient")
"""A conductor's extinction coefficient k: [0, 100]."""

_TINY = 1e-30  # guards divisions by squared cosines (representable in float32)
_GAUSS_LEGENDRE_NODES = 64  # the default order of _quadrature
# Orders of the Gauss–Legendre rules of TorranceSparrowGaussian, each the smallest whose error
# against a 512-point reference is at rounding over the whole (m, θ) domain (scanned in
# tests/brdf/test_microfacet.py): the CDF ∫_0^θ e^{-(s/m)²} sin 2s ds (max. relative error
# 5e-15 at 24 nodes, 1.4e-13 at 20), and Λ (|ΔΛ|/(1+Λ) ≤ 7e-14 at 32 nodes, 3.5e-13 at 28).
_GAUSSIAN_CDF_NODES = 24
_GAUSSIAN_GUESS_NODES = 12  # the sampler's first Newton steps: relative error ≤ 2e-6
_GAUSSIAN_LAMBDA_NODES = 32
_GAUSSIAN_SUPPORT = 6.0  # exp(-(θ/m)²) < 3e-16 beyond θ = 6 m
# The sampler's Newton steps (on the 12-point CDF, then on the 24-point one) by precision: the
# fewest that reach rounding over m ∈ [10⁻⁴, 10], u ∈ [0, 1] (scanned in
# tests/brdf/test_microfacet.py): float64 |ΔCDF| ≤ 6e-15 with (3, 2), 2.5e-13 with (2, 2);
# float32 ≤ 4e-7 (3 ulp of u) with (2, 1).
_GAUSSIAN_NEWTON_STEPS = {"float64": (3, 2), "float32": (2, 1)}


@functools.lru_cache(maxsize=8)
def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1), 0.5 * w


def _quadrature(like: Array, n: int = _GAUSS_LEGENDRE_NODES) -> tuple[Array, Array]:
    """``n``-point Gauss–Legendre nodes and weights on [0, 1], in the dtype/device of ``like``."""
    x, w = _gauss_legendre(n)
    return asarray(x, like=like, dtype=like.dtype), asarray(w, like=like, dtype=like.dtype)


# --------------------------------------------------------------------------- distributions
class MicrofacetDistribution:
    r"""Base of the microfacet normal distributions (frozen dataclasses).

    Subclasses give :math:`D` (:meth:`D`), Smith's :math:`\Lambda` (:meth:`smith_lambda`), a
    :math:`D\cos\theta_m` sampler (:meth:`sample`) and, where they can, visible-normal
    sampling. Directions are local unit vectors ``(..., 3)``.
    """

    isotropic: bool = True
    supports_visible_sampling: bool = False

    def D(self, wm: Array) -> Array:
        r"""Normal distribution :math:`D(\omega_m)`, ``(..., C)``; 0 below the surface."""
        raise NotImplementedError

    def smith_lambda(self, w: Array) -> Array:
        r"""Smith's :math:`\Lambda(\omega)` (Heitz 2014 eq. 72), ``(..., C)``; even in ``w.z``."""
        raise NotImplementedError

    def sample(self, u: Array) -> Array:
        r"""A normal :math:`\omega_m` with density :math:`D(\omega_m)\cos\theta_m` (:meth:`pdf`)."""
        raise NotImplementedError

    def pdf(self, wm: Array) -> Array:
        r"""Solid-angle density :math:`D(\omega_m)\cos\theta_m` of :meth:`sample`, ``(...,)``."""
        raise NotImplementedError

    def G1(self, w: Array, wm: Array) -> Array:
        r"""Smith masking :math:`G_1(\omega,\omega_m) = \chi^+((\omega\cdot\omega_m)\,
        \omega_z) / (1 + \Lambda(\omega))`, ``(..., C)``.

        The characteristic function keeps the back of a facet invisible from either side
        (for ``w`` below the surface the facet must face down along ``w`` too).

        References
        ----------
        .. [1] E. Heitz, "Understanding the masking-shadowing function", JCGT 3(2), 2014, eq. 43.
        """
        xp = namespace(w, wm)
        visible = (dot(w, wm, keepdims=True) * w[..., 2:3]) > 0
        g1 = self.smith_G1(w)
        return xp.where(visible, g1, constant(0, g1))

    def smith_G1(self, w: Array) -> Array:
        r"""Smith's :math:`1/(1 + \Lambda(\omega))` without the facet test of :meth:`G1`,
        ``(..., C)``."""
        return 1 / (1 + self.smith_lambda(w))

    def pdf_visible(self, w: Array, wm: Array) -> Array:
        r"""Density of the normals visible from ``w`` (upper hemisphere), ``(...,)``:
        :math:`D_\omega(\omega_m) = G_1(\omega,\omega_m)\max(0,\omega\cdot\omega_m)
        D(\omega_m)/\cos\theta`, with the channel-mean roughness of the samplers.

        References
        ----------
        .. [1] E. Heitz, E. d'Eon, "Importance sampling microfacet-based BSDFs using the
               distribution of visible normals", EGSR 2014, eq. 2.
        """
        mean = self.channel_mean()
        xp = namespace(w, wm)
        cos_theta = w[..., 2]
        value = mean.G1(w, wm)[..., 0] * xp.maximum(dot(w, wm), xp.zeros_like(cos_theta))
        value = value * mean.D(wm)[..., 0]
        return safe_div(value, xp.abs(cos_theta))

    def channel_mean(self) -> MicrofacetDistribution:
        """This distribution with each channel-varying parameter replaced by its channel mean."""
        raise NotImplementedError


def _mean_over_channels(value: Any) -> Any:
    """A channel-valued parameter averaged over its last axis (kept as an axis of length 1).

    Python sequences stay Python numbers (so that they take the dtype of the data they meet);
    arrays keep their backend, dtype and autograd graph.
    """
    if isinstance(value, list | tuple):
        return (
            [float(np.mean(np.asarray(value, dtype=np.float64), axis=-1))]
            if len(value) > 1
            else value
        )
    if not hasattr(value, "shape") or value.ndim == 0 or value.shape[-1] == 1:
        return value
    return namespace(value).mean(value, axis=-1, keepdims=True)


@dataclass(frozen=True, eq=False)
class _StretchedDistribution(MicrofacetDistribution):
    r"""A distribution of slopes shape-invariant under stretching (Beckmann, GGX).

    With the standard (α = 1) isotropic slope density :math:`P^{22}_1`, the anisotropic one is
    :math:`P^{22}(x, y) = P^{22}_1(x/\alpha_x, y/\alpha_y)/(\alpha_x\alpha_y)` and
    :math:`D(\omega_m) = P^{22}(-m_x/m_z, -m_y/m_z)/\cos^4\theta_m`; Λ depends on ω only through
    :math:`a = 1/(\alpha(\phi)\tan\theta)`,
    :math:`\alpha(\phi)^2\tan^2\theta = (\alpha_x^2\omega_x^2+\alpha_y^2\omega_y^2)/\omega_z^2`.
    """

    alpha_x: Any = 0.1
    alpha_y: Any = None
    supports_visible_sampling = True

    def __post_init__(self) -> None:
        if self.alpha_y is None:
            object.__setattr__(self, "alpha_y", self.alpha_x)
        ROUGHNESS.check("alpha_x", self.alpha_x)
        ROUGHNESS.check("alpha_y", self.alpha_y)
        channel_count(self.alpha_x, self.alpha_y, names=("alpha_x", "alpha_y"))

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.alpha_y is self.alpha_x or bool(
            np.array_equal(to_numpy(self.alpha_x), to_numpy(self.alpha_y))
        )

    def channel_mean(self) -> MicrofacetDistribution:
        return type(self)(
            _mean_over_channels(self.alpha_x), _mean_over_channels(self.alpha_y), **self._extra()
        )

    def _extra(self) -> dict[str, Any]:
        return {}

    def _alphas(self, like: Array) -> tuple[Array, Array]:
        return param(self.alpha_x, like), param(self.alpha_y, like)

    def _alpha2_sin2(self, w: Array) -> Array:
        r""":math:`\alpha(\phi)^2\sin^2\theta` of ``w`` (times :math:`|w|^2`), ``(..., C)``."""
        alpha_x, alpha_y = self._alphas(w)
        return (alpha_x * w[..., 0:1]) ** 2 + (alpha_y * w[..., 1:2]) ** 2

    def _slope_tan2(self, w: Array) -> Array:
        r""":math:`\alpha(\phi)^2\tan^2\theta` of ``w``, ``(..., C)``."""
        xp = namespace(w)
        wz = w[..., 2:3]
        return self._alpha2_sin2(w) / xp.maximum(wz * wz, constant(_TINY, wz))

    def _standard_slope_density(self, r2: Array) -> Array:
        """Isotropic standard slope density :math:`P^{22}_1` at squared slope ``r2``."""
        raise NotImplementedError

    def D(self, wm: Array) -> Array:
        xp = namespace(wm)
        alpha_x, alpha_y = self._alphas(wm)
        mx, my, mz = wm[..., 0:1], wm[..., 1:2], wm[..., 2:3]
        cos2 = xp.maximum(mz * mz, constant(_TINY, mz))
        r2 = ((mx / alpha_x) ** 2 + (my / alpha_y) ** 2) / cos2
        value = self._standard_slope_density(r2) / (alpha_x * alpha_y * cos2 * cos2)
        return xp.where(mz > 0, value, constant(0, value))

    def _standard_radius2(self, u: Array) -> Array:
        """Squared standard slope radius tan²θ for α = 1, by inverting its radial CDF at ``u``."""
        raise NotImplementedError

    def sample(self, u: Array) -> Array:
        r"""Normals with density :math:`D\cos\theta_m`: sample the standard slope density by
        inverting its radial CDF, scale the slopes by :math:`(\alpha_x, \alpha_y)` and set
        :math:`\omega_m \propto (-x, -y, 1)` (shape invariance, Heitz 2014 §5.3).
        """
        xp = namespace(u)
        mean = self.channel_mean()
        alpha_x, alpha_y = mean._alphas(u)
        r = safe_sqrt(self._standard_radius2(u[..., 0:1]))
        phi = (2 * math.pi) * u[..., 1:2]
        slope_x = r * xp.cos(phi) * alpha_x
        slope_y = r * xp.sin(phi) * alpha_y
        slope_x, slope_y = xp.broadcast_arrays(slope_x, slope_y)
        return normalize(xp.concat([-slope_x, -slope_y, xp.ones_like(slope_x)], axis=-1))

    def pdf(self, wm: Array) -> Array:
        xp = namespace(wm)
        value = self.channel_mean().D(wm)[..., 0] * wm[..., 2]
        return xp.maximum(value, xp.zeros_like(value))

    def sample_visible(self, w: Array, u: Array) -> Array:
        r"""A normal drawn from the distribution of normals visible from ``w`` (``w.z > 0``),
        with density :meth:`pdf_visible`. ``u`` is ``(..., 2)`` uniforms."""
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class GGX(_StretchedDistribution):
    r"""The GGX / Trowbridge–Reitz distribution (anisotropic).

    .. math::
        D(\omega_m) = \frac{1}{\pi\alpha_x\alpha_y\cos^4\theta_m
            \left(1 + \tan^2\theta_m(\cos^2\phi_m/\alpha_x^2 + \sin^2\phi_m/\alpha_y^2)\right)^2},
        \qquad \Lambda(\omega) = \frac{-1 + \sqrt{1 + \alpha(\phi)^2\tan^2\theta}}{2}.

    Visible normals are sampled exactly by Heitz (2018): stretch ω to the α = 1 configuration,
    sample the projected hemisphere of normals (a disk warped by ½(1 + cos θ)), unstretch.

    Parameters
    ----------
    alpha_x, alpha_y : roughness along the tangent x and bitangent y, in [10⁻⁴, 10] (α = 1 is
        very rough); ``alpha_y`` defaults to ``alpha_x`` (isotropic). Scalars or per channel.

    References
    ----------
    .. [1] T. S. Trowbridge, K. P. Reitz, JOSA 65(5), 1975.
    .. [2] B. Walter et al., "Microfacet models for refraction through rough surfaces", EGSR
           2007, eqs. 33-34.
    .. [3] E. Heitz, "Understanding the masking-shadowing function", JCGT 3(2), 2014, eq. 86.
    .. [4] E. Heitz, "Sampling the GGX distribution of visible normals", JCGT 7(4), 2018.
    """

    def D(self, wm: Array) -> Array:
        r"""The formula above with :math:`\cos^4\theta_m(1 + \tan^2\theta_m(\ldots))^2 =
        (\cos^2\theta_m + \sin^2\theta_m(\ldots))^2` for unit ``wm``: one division, and no
        :math:`\tan` to guard at grazing normals."""
        xp = namespace(wm)
        alpha_x, alpha_y = self._alphas(wm)
        mx, my, mz = wm[..., 0:1], wm[..., 1:2], wm[..., 2:3]
        denominator = mz * mz + (mx / alpha_x) ** 2 + (my / alpha_y) ** 2
        value = 1 / (math.pi * alpha_x * alpha_y * denominator * denominator)
        return xp.where(mz > 0, value, constant(0, value))

    def _standard_radius2(self, u: Array) -> Array:
        xp = namespace(u)
        u = clamp(u, 0.0, 1 - 1e-7)
        return u / (1 - u) + xp.zeros_like(u)

    def smith_lambda(self, w: Array) -> Array:
        s2 = self._slope_tan2(w)
        return 0.5 * (safe_sqrt(1 + s2) - 1)

    def smith_G1(self, w: Array) -> Array:
        r""":math:`1/(1+\Lambda) = 2/(1 + \sqrt{1 + \alpha^2\tan^2\theta}) =
        2|\cos\theta| / (|\cos\theta| + \sqrt{\cos^2\theta + \alpha^2\sin^2\theta})`: one
        division instead of two (the form of Mitsuba 3's ``smith_g1``), exact at grazing."""
        xp = namespace(w)
        cos_theta = xp.abs(w[..., 2:3])
        root = safe_sqrt(cos_theta * cos_theta + self._alpha2_sin2(w))
        return safe_div(2 * cos_theta, cos_theta + root)

    @per_direction
    def _visible_frame(self, w: Array) -> tuple[Array, Array, Array, Array]:
        """What :meth:`sample_visible` owes to ``w`` alone: the stretched direction vh, the
        frame (t1, t2) about it and the blend s = (1 + vh_z)/2, each ``(..., 3)`` (s
        ``(..., 1)``); made once per direction of a broadcast ``w`` (:func:`per_direction`)."""
        xp = namespace(w)
        alpha_x, alpha_y = self.channel_mean()._alphas(w)
        vx, vy, vz = w[..., 0:1], w[..., 1:2], w[..., 2:3]
        vh = normalize(xp.concat(xp.broadcast_arrays(alpha_x * vx, alpha_y * vy, vz), axis=-1))
        lensq = vh[..., 0:1] ** 2 + vh[..., 1:2] ** 2
        inv_len = safe_div(xp.ones_like(lensq), safe_sqrt(lensq))
        t1 = xp.concat(
            [-vh[..., 1:2] * inv_len, vh[..., 0:1] * inv_len, xp.zeros_like(lensq)], axis=-1
        )
        x_axis = xp.concat(
            [xp.ones_like(lensq), xp.zeros_like(lensq), xp.zeros_like(lensq)], axis=-1
        )
        t1 = xp.where(lensq > 0, t1, x_axis)
        t2 = cross(vh, t1)
        return vh, t1, t2, 0.5 * (1 + vh[..., 2:3])

    def sample_visible(self, w: Array, u: Array) -> Array:
        xp = namespace(w, u)
        alpha_x, alpha_y = self.channel_mean()._alphas(w)
        vh, t1, t2, s = self._visible_frame(w)
        r = xp.sqrt(u[..., 0:1])
        phi = (2 * math.pi) * u[..., 1:2]
        p1 = r * xp.cos(phi)
        p2 = r * xp.sin(phi)
        p2 = (1 - s) * safe_sqrt(1 - p1 * p1) + s * p2
        nh = p1 * t1 + p2 * t2 + safe_sqrt(1 - p1 * p1 - p2 * p2) * vh
        ne = xp.concat(
            [
                alpha_x * nh[..., 0:1],
                alpha_y * nh[..., 1:2],
                xp.maximum(nh[..., 2:3], xp.zeros_like(nh[..., 2:3])),
            ],
            axis=-1,
        )
        return normalize(ne)


@dataclass(frozen=True, eq=False)
class Beckmann(_StretchedDistribution):
    r"""The Beckmann distribution (anisotropic): Gaussian slopes of rms :math:`\alpha/\sqrt2`.

    .. math::
        D(\omega_m) = \frac{\exp\left(-\tan^2\theta_m(\cos^2\phi_m/\alpha_x^2
            + \sin^2\phi_m/\alpha_y^2)\right)}{\pi\alpha_x\alpha_y\cos^4\theta_m},
        \qquad \Lambda(\omega) = \frac{\operatorname{erf}(a) - 1}{2}
            + \frac{e^{-a^2}}{2a\sqrt\pi},\quad a = \frac{1}{\alpha(\phi)\tan\theta}.

    ``approximate_g1=True`` replaces the exact Λ by the rational fit of Walter et al. (2007,
    eq. 27) to :math:`G_1 = 1/(1+\Lambda)`,
    :math:`G_1 \approx (3.535a + 2.181a^2)/(1 + 2.276a + 2.577a^2)` for a < 1.6 and 1 above
    (< 0.35 % error), which is what Mitsuba 3 evaluates; use it to match Mitsuba exactly.

    Visible normals are sampled by Jakob's (2014) numerical inversion of the Heitz–d'Eon
    (2014) slope CDF in the erf domain, as Mitsuba 3's ``sample_visible_11``.

    Parameters
    ----------
    alpha_x, alpha_y : roughness along the tangent x and bitangent y, in [10⁻⁴, 10]
        (α = √2 × rms slope); ``alpha_y`` defaults to ``alpha_x``. Scalars or per channel.
    approximate_g1 : use Walter's rational G1 (default False: the exact Smith Λ).

    References
    ----------
    .. [1] P. Beckmann, A. Spizzichino, *The Scattering of Electromagnetic Waves from Rough
           Surfaces*, 1963.
    .. [2] B. Walter et al., EGSR 2007, eqs. 25-27.
    .. [3] E. Heitz, JCGT 3(2), 2014, eq. 80.
    .. [4] E. Heitz, E. d'Eon, EGSR 2014; W. Jakob, "An improved visible normal sampling routine
           for the Beckmann distribution", 2014.
    """

    approximate_g1: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        check_flag("approximate_g1", self.approximate_g1)

    def _extra(self) -> dict[str, Any]:
        return {"approximate_g1": self.approximate_g1}

    def _standard_slope_density(self, r2: Array) -> Array:
        return namespace(r2).exp(-r2) / math.pi

    def _standard_radius2(self, u: Array) -> Array:
        xp = namespace(u)
        return -xp.log1p(-clamp(u, 0.0, 1 - 1e-16))

    @per_direction
    def smith_lambda(self, w: Array) -> Array:
        """Λ of the class docstring (erf); made once per direction of a broadcast ``w``
        (:func:`~brdfkit.brdf.base.per_direction`)."""
        xp = namespace(w)
        s2 = self._slope_tan2(w)
        a = 1 / xp.sqrt(xp.maximum(s2, constant(_TINY, s2)))
        if self.approximate_g1:
            a2 = a * a
            g1 = (3.535 * a + 2.181 * a2) / (1 + 2.276 * a + 2.577 * a2)
            return xp.where(a < 1.6, 1 / g1 - 1, xp.zeros_like(a))
        return 0.5 * (erf(a) - 1) + xp.exp(-a * a) / (2 * math.sqrt(math.pi) * a)

    @per_direction
    def _visible_setup(self, w: Array) -> tuple[Array, ...]:
        """What :meth:`sample_visible` owes to ``w`` alone, each ``(..., 1)``: the azimuth's
        cos φ and sin φ of the stretched direction and :func:`_beckmann_direction_terms` of
        its cos θ; made once per direction of a broadcast ``w`` (:func:`per_direction`)."""
        xp = namespace(w)
        alpha_x, alpha_y = self.channel_mean()._alphas(w)
        w_p = normalize(
            xp.concat(
                xp.broadcast_arrays(alpha_x * w[..., 0:1], alpha_y * w[..., 1:2], w[..., 2:3]),
                axis=-1,
            )
        )
        sin_theta = safe_sqrt(w_p[..., 0:1] ** 2 + w_p[..., 1:2] ** 2)
        has_phi = sin_theta > 0
        safe_sin = xp.where(has_phi, sin_theta, xp.ones_like(sin_theta))
        cos_phi = xp.where(has_phi, w_p[..., 0:1] / safe_sin, xp.ones_like(sin_theta))
        sin_phi = xp.where(has_phi, w_p[..., 1:2] / safe_sin, xp.zeros_like(sin_theta))
        return cos_phi, sin_phi, *_beckmann_direction_terms(w_p[..., 2:3])

    def sample_visible(self, w: Array, u: Array) -> Array:
        xp = namespace(w, u)
        alpha_x, alpha_y = self.channel_mean()._alphas(w)
        cos_phi, sin_phi, *terms = self._visible_setup(w)
        slope_x, slope_y = _beckmann_visible_slopes(terms, u)
        slope_x, slope_y = (
            (cos_phi * slope_x - sin_phi * slope_y) * alpha_x,
            (sin_phi * slope_x + cos_phi * slope_y) * alpha_y,
        )
        return normalize(xp.concat([-slope_x, -slope_y, xp.ones_like(slope_x)], axis=-1))


_BECKMANN_NEWTON_STEPS = 5


def _beckmann_direction_terms(cos_theta: Array) -> tuple[Array, Array, Array]:
    r""":func:`_beckmann_visible_slopes`' terms of the incidence alone, from its ``cos_theta``:
    tan θ (floored at 10⁻¹²), the largest value :math:`\operatorname{erf}(\cot\theta)` of x and
    the CDF's total :math:`1 + \operatorname{erf}(\cot\theta) + \tan\theta\,
    e^{-\cot^2\theta}/\sqrt\pi`."""
    xp = namespace(cos_theta)
    inv_sqrt_pi = 1 / math.sqrt(math.pi)
    tan_theta = safe_sqrt(1 - cos_theta * cos_theta) / cos_theta
    tan_theta = xp.maximum(tan_theta, constant(1e-12, tan_theta))
    cot_theta = 1 / tan_theta
    max_value = erf(cot_theta)
    total = 1 + max_value + inv_sqrt_pi * tan_theta * xp.exp(-cot_theta * cot_theta)
    return tan_theta, max_value, total


def _beckmann_visible_slopes(terms: tuple[Array, Array, Array], u: Array) -> tuple[Array, Array]:
    r"""Slopes of the standard (α = 1) Beckmann visible normals for an incidence in the
    xz-plane, given its :func:`_beckmann_direction_terms` ``terms``: Jakob's Newton inversion
    in :math:`x = \operatorname{erf}(\tilde x)` of
    :math:`1 + x + \tan\theta\, e^{-\operatorname{erfinv}(x)^2}/\sqrt\pi = u_1 C`, and
    :math:`\tilde y = \operatorname{erfinv}(2u_2 - 1)`.

    References
    ----------
    .. [1] W. Jakob, "An improved visible normal sampling routine for the Beckmann
           distribution", 2014; Mitsuba 3 ``MicrofacetDistribution::sample_visible_11``.
    """
    tan_theta, max_value, total = terms
    xp = namespace(tan_theta, u)
    inv_sqrt_pi = 1 / math.sqrt(math.pi)
    eps = 1e-6 if tan_theta.dtype == xp.float32 else 1e-12
    u = clamp(u, eps, 1 - eps)
    u1, u2 = u[..., 0:1], u[..., 1:2]
    x = max_value - (max_value + 1) * erf(xp.sqrt(-xp.log(u1)))
    target = u1 * total
    lo = -xp.ones_like(x) + eps
    hi = max_value - eps
    for _ in range(_BECKMANN_NEWTON_STEPS):
        x = xp.minimum(xp.maximum(x, lo), hi)
        slope = erfinv(x)
        value = 1 + x + inv_sqrt_pi * tan_theta * xp.exp(-slope * slope) - target
        derivative = 1 - slope * tan_theta
        x = x - value / derivative
    x = xp.minimum(xp.maximum(x, lo), hi)
    return erfinv(x), erfinv(2 * u2 - 1)


@dataclass(frozen=True, eq=False)
class TorranceSparrowGaussian(MicrofacetDistribution):
    r"""The Gaussian distribution of facet angles of Torrance & Sparrow (1967).

    .. math::
        D(\omega_m) = c(m)\, e^{-(\theta_m/m)^2},\qquad
        c(m)^{-1} = 2\pi\int_0^{\pi/2} e^{-(\theta/m)^2}\cos\theta\sin\theta\,d\theta,

    with θm = α_h the angle between the facet normal (the half vector) and n; the lectures
    write it :math:`e^{-\alpha^2/(2\sigma_\alpha^2)}`, so :math:`m = \sqrt2\,\sigma_\alpha`.
    The normalisation :math:`\int D\cos\theta_m\,d\omega_m = 1` is computed numerically by
    24-point Gauss–Legendre quadrature in :math:`t = \theta/m` over
    :math:`[0, \min(\pi/(2m), 6)]` (exact to rounding: ≤ 5e-15 relative against 512 points
    over the whole domain; the tail beyond 6m is < 3e-16), which stays differentiable in m.
    For small m, :math:`c \to 1/(\pi m^2)`, Beckmann's value.

    The distribution has no closed-form Smith Λ; :meth:`smith_lambda` integrates Heitz's
    (2014, eq. 72) projected area numerically: with the azimuthal integral in closed form,
    :math:`\Lambda(\omega) = \int_{\pi/2-\theta}^{\pi/2} D\sin\theta_m
    \left[I(\theta,\theta_m)/\cos\theta - 2\pi\cos\theta_m\right]d\theta_m`,
    :math:`I = \int_0^{2\pi}\max(0,\cos\theta\cos\theta_m+\sin\theta\sin\theta_m\cos\phi)d\phi`,
    by 32-point Gauss–Legendre quadrature in :math:`s`, :math:`\theta_m = \pi/2-\theta +
    (\text{span})\,s^2` (which smooths the :math:`(\theta_m-\pi/2+\theta)^{3/2}` onset of
    partial visibility): :math:`|\Delta\Lambda|/(1+\Lambda) \le 7\cdot10^{-14}` against
    a 512/1024-point reference over m ∈ [10⁻⁴, 10] and θ up to 10⁻⁸ from grazing (the
    64-point rule of earlier versions: 3e-14, i.e. both at the rounding of the integrand).
    :meth:`sample` draws :math:`D\cos\theta_m` by inverting the CDF in θm: a fixed number
    of safeguarded Newton steps on :math:`\log(1-\mathrm{CDF})` in :math:`-\log\cos^2\theta`
    (:meth:`_invert_cdf`), three on a 12-point CDF (relative error ≤ 2e-6), then two on the
    exact 24-point one (one and one in float32); the CDF error is at rounding (≤ 6e-15 in
    float64, ≤ 3e-7 in float32), and the sampler compiles (:mod:`brdfkit.compiled`). There
    is no visible-normal sampler.

    Parameters
    ----------
    m : width of the angular Gaussian in radians, in [10⁻⁴, 10] (0.1 is glossy, 0.5 rough).

    References
    ----------
    .. [1] K. E. Torrance, E. M. Sparrow, "Theory for off-specular reflection from roughened
           surfaces", JOSA 57(9):1105-1114, 1967.
    .. [2] R. L. Cook, K. E. Torrance, ACM TOG 1(1), 1982, eq. (the Gaussian model).
    .. [3] E. Heitz, JCGT 3(2), 2014, §5.
    """

    m: Any = 0.2

    def __post_init__(self) -> None:
        GAUSSIAN_WIDTH.check("m", self.m)

    def channel_mean(self) -> MicrofacetDistribution:
        return TorranceSparrowGaussian(_mean_over_channels(self.m))

    def _integral(self, m: Array, lower: Array, upper: Array, order: int) -> Array:
        r""":math:`\int_{ma}^{mb} e^{-(s/m)^2}\sin 2s\,ds = m\int_a^b e^{-t^2}\sin(2mt)\,dt`
        between ``lower`` a and ``upper`` b (in :math:`t = s/m`) by ``order``-point
        Gauss–Legendre quadrature."""
        xp = namespace(m, lower, upper)
        nodes, weights = _quadrature(m, order)
        span = upper - lower
        t = lower[..., None] + span[..., None] * nodes
        integrand = xp.exp(-t * t) * xp.sin(2 * m[..., None] * t)
        return m * span * xp.sum(weights * integrand, axis=-1)

    def _partial_integral(self, m: Array, theta: Array, order: int = _GAUSSIAN_CDF_NODES) -> Array:
        r""":math:`P(\theta) = \int_0^{\theta} e^{-(s/m)^2}\sin 2s\,ds` by ``order``-point
        Gauss–Legendre quadrature in :math:`t = s/m` over :math:`[0, \min(\theta/m, 6)]`.

        The integrand :math:`e^{-t^2}\sin(2mt)` is entire and its domain bounded
        (:math:`t \le 6`, :math:`2mt \le \pi`), so the error of the rule is uniform over it:
        at the default 24 points it is at rounding (≤ 5e-15 relative against a 512-point
        reference on a scan of m ∈ [10⁻⁴, 10], θ ∈ (0, π/2]; 1.4e-13 at 20 points).
        """
        xp = namespace(m, theta)
        upper = xp.minimum(theta / m, constant(_GAUSSIAN_SUPPORT, m))
        return self._integral(m, xp.zeros_like(upper), upper, order)

    def normalization(self, like: Array) -> Array:
        r"""The constant :math:`c(m)` making :math:`\int D\cos\theta_m\,d\omega_m = 1`."""
        m = param(self.m, like)
        return 1 / (math.pi * self._partial_integral(m, constant(math.pi / 2, m) + 0 * m))

    def D(self, wm: Array) -> Array:
        xp = namespace(wm)
        m = param(self.m, wm)
        theta = xp.acos(clamp(wm[..., 2:3], -1.0, 1.0))
        value = self.normalization(wm) * xp.exp(-((theta / m) ** 2))
        return xp.where(wm[..., 2:3] > 0, value, xp.zeros_like(value))

    @per_direction
    def smith_lambda(self, w: Array) -> Array:
        """Λ by the 32-point quadrature of the class docstring; made once per direction of a
        broadcast ``w`` (:func:`~brdfkit.brdf.base.per_direction`: the fixed ωo of a sampler's
        checks, of an albedo estimate, of a quadrature ring's kernel)."""
        xp = namespace(w)
        m = param(self.m, w)
        cos_theta = clamp(xp.abs(w[..., 2:3]), 0.0, 1.0)
        sin_theta = safe_sqrt(1 - cos_theta * cos_theta)
        theta = xp.acos(cos_theta)
        lower = math.pi / 2 - theta  # facets steeper than this are partly back-facing
        upper = xp.minimum(constant(math.pi / 2, m), _GAUSSIAN_SUPPORT * m)
        span = xp.maximum(upper - lower, xp.zeros_like(lower * upper))
        nodes, weights = _quadrature(w, _GAUSSIAN_LAMBDA_NODES)
        # θm = lower + span s²: smooths the (θm − lower)^{3/2} onset of partial visibility.
        s = nodes
        theta_m = lower[..., None] + span[..., None] * s * s
        jac = 2 * span[..., None] * s
        a = cos_theta[..., None] * xp.cos(theta_m)
        sin_theta_m = xp.sin(theta_m)
        b = sin_theta[..., None] * sin_theta_m
        ratio = clamp(safe_div(-a, b), -1.0, 1.0)
        phi0 = xp.acos(ratio)
        azimuthal = 2 * (a * phi0 + b * safe_sqrt(1 - ratio * ratio))
        excess = safe_div(azimuthal, cos_theta[..., None]) - 2 * math.pi * xp.cos(theta_m)
        density = self.normalization(w)[..., None] * xp.exp(-((theta_m / m[..., None]) ** 2))
        integrand = density * sin_theta_m * excess * jac
        value = xp.sum(weights * integrand, axis=-1)
        grazing = cos_theta <= 0
        return xp.where(grazing, constant(math.inf, value) + 0 * value, value)

    def _invert_cdf(self, m: Array, u: Array) -> Array:
        r"""The θm ∈ [0, π/2) whose CDF is ``u`` ∈ [0, 1): a fixed number of safeguarded Newton
        steps on the log-survival :math:`h = \log(1 - \mathrm{CDF})` in
        :math:`w = -\log\cos^2\theta` (:math:`\theta = \arctan\sqrt{e^w - 1}`).

        h is nearly linear in w at both ends: :math:`h \approx -w/m^2` for small θ and m, and
        :math:`h \approx -w + \text{const}` as θ → π/2, where the CDF's :math:`\sin 2s`
        vanishes. Two upper bounds on the root start the iteration and bound it: the CDF
        exceeds the uniform one :math:`\sin^2\theta` (the Gaussian's likelihood ratio to it
        decreases), and :math:`\log(1 - \mathrm{CDF})` is concave in :math:`(\theta/m)^2`
        (its density is log-concave there: :math:`e^{-s}\,\mathrm{sinc}(2m\sqrt s)` with
        :math:`\mathrm{sinc}` a product of factors linear in s), so that its tangent at 0 gives
        :math:`\theta \le \sqrt{-\log(1-u)\,P(\pi/2)}`. A step leaving the bracket of the
        root is replaced by bisection. Below the median h is computed from P, the partial
        integral (which keeps θ's relative precision as u → 0), above it from the tail, so that
        h is accurate to rounding where it matters. The steps (:data:`_GAUSSIAN_NEWTON_STEPS`)
        run on the 12-point CDF first, then on the 24-point one; with no data-dependent exit,
        the iteration traces to one branch-free expression for :mod:`brdfkit.compiled`.
        """
        xp = namespace(m, u)
        eps = float(xp.finfo(u.dtype).eps)
        zero = xp.zeros_like(u)
        end = xp.minimum(constant(math.pi / 2, m) / m, constant(_GAUSSIAN_SUPPORT, m))
        # P(π/2) once per value of m (shape (1,) for a scalar m), not once per sample
        totals = {
            n: self._integral(m, xp.zeros_like(end), end, n)
            for n in (_GAUSSIAN_GUESS_NODES, _GAUSSIAN_CDF_NODES)
        }
        end = end + zero
        log_survival = xp.log1p(-u)
        below_median = u < 0.5
        theta = xp.minimum(
            xp.sqrt(-log_survival * totals[_GAUSSIAN_CDF_NODES]), xp.asin(xp.sqrt(u))
        )
        w = xp.log1p(xp.tan(theta) ** 2)
        # The bracket's end: the bound, widened to hold the quadratures' roots, which lie within
        # rounding of it where the bound is tight (small m; m → ∞) or 1e-6 relative (12 points)
        bound = w * (1 + 1e-3)
        guess, exact = _GAUSSIAN_NEWTON_STEPS["float32" if eps > 1e-10 else "float64"]
        for order, steps in ((_GAUSSIAN_GUESS_NODES, guess), (_GAUSSIAN_CDF_NODES, exact)):
            # the bracket of this quadrature's root (the 12-point root is not the exact one)
            lo, hi = zero, bound
            for _ in range(steps):
                total = totals[order]
                t = xp.minimum(theta / m, end)
                part = self._integral(
                    m, xp.where(below_median, zero, t), xp.where(below_median, t, end), order
                )
                tail = xp.maximum(xp.where(below_median, total - part, part), constant(_TINY, u))
                log_tail = xp.where(below_median, xp.log1p(-part / total), xp.log(tail / total))
                excess = log_tail - log_survival  # > 0: θ below the root
                lo = xp.where(excess > 0, w, lo)
                hi = xp.where(excess > 0, hi, w)
                rate = xp.exp(-t * t) * xp.cos(theta) ** 2 / tail  # −dh/dw
                newton = w + excess / rate
                w = xp.where((newton >= lo) & (newton <= hi), newton, 0.5 * (lo + hi))
                theta = xp.atan(xp.sqrt(xp.expm1(w)))
        return theta

    def sample(self, u: Array) -> Array:
        xp = namespace(u)
        m = param(self.channel_mean().m, u)
        # u1 < 1 by a margin the dtype resolves (1 - 1e-12 is 1 in float32)
        u_max = 1 - max(1e-12, float(xp.finfo(u.dtype).eps))
        theta = self._invert_cdf(m, clamp(u[..., 0:1], 0.0, u_max) + 0 * m)
        phi = (2 * math.pi) * u[..., 1:2]
        sin_theta = xp.sin(theta)
        sin_theta, cos_phi, sin_phi = xp.broadcast_arrays(sin_theta, xp.cos(phi), xp.sin(phi))
        return xp.concat(
            [
                sin_theta * cos_phi,
                sin_theta * sin_phi,
                xp.broadcast_to(xp.cos(theta), sin_theta.shape),
            ],
            axis=-1,
        )

    def pdf(self, wm: Array) -> Array:
        xp = namespace(wm)
        value = self.channel_mean().D(wm)[..., 0] * wm[..., 2]
        return xp.maximum(value, xp.zeros_like(value))


# --------------------------------------------------------------------------- masking
def masking_shadowing(
    distribution: MicrofacetDistribution,
    wi: Array,
    wo: Array,
    wm: Array,
    kind: str,
    transmission: bool = True,
) -> Array:
    r"""Joint masking–shadowing :math:`G_2(\omega_i,\omega_o,\omega_m)`, ``(..., C)``.

    - ``"v_groove"`` (Torrance & Sparrow 1967; Cook & Torrance 1982; the lectures):
      :math:`\min\left(1, \frac{2(n\cdot h)(n\cdot\omega_o)}{\omega_o\cdot h},
      \frac{2(n\cdot h)(n\cdot\omega_i)}{\omega_o\cdot h}\right)` for reflection (h = ωm).
      It is the V-cavity microsurface of Heitz (2014 §5.3): its
      :math:`G_1 = \min(1, 2\cos\theta_h\cos\theta_o/(\omega_o\cdot h))` satisfies the weak
      white furnace for *any* D, and :math:`G_2 = \min(G_1(\omega_i), G_1(\omega_o))`.
    - ``"smith_separable"``: :math:`G_1(\omega_i,\omega_m)G_1(\omega_o,\omega_m)` (Walter et al.
      2007, Mitsuba 3).
    - ``"smith_correlated"``: height-correlated Smith (Heitz 2014 eq. 99),
      :math:`\chi^+\chi^+/(1+\Lambda(\omega_i)+\Lambda(\omega_o))` for reflection and
      :math:`\chi^+\chi^+ B(1+\Lambda(\omega_i), 1+\Lambda(\omega_o))` (Beta function, Heitz
      2014 §6.2) when ωi and ωo lie on opposite sides (transmission).

    ``transmission=False`` is for a reflection model, whose value is 0 for pairs on opposite
    sides: ``"smith_correlated"`` then gives every pair the reflection form and skips the Beta
    function (a fixed choice of formula, not a test of the values, so that array-API tracing
    sees one expression).

    Raises
    ------
    brdfkit.errors.ParameterError
        For an unknown ``kind``.

    References
    ----------
    .. [1] K. E. Torrance, E. M. Sparrow, JOSA 57(9), 1967.
    .. [2] B. Walter et al., EGSR 2007, eq. 23.
    .. [3] E. Heitz, "Understanding the masking-shadowing function", JCGT 3(2), 2014, §6.
    """
    xp = namespace(wi, wo, wm)
    if kind == "v_groove":
        cos_h = wm[..., 2:3]
        wo_h = dot(wo, wm, keepdims=True)
        wi_h = dot(wi, wm, keepdims=True)
        ok = (wo_h > 0) & (wi_h > 0) & (wi[..., 2:3] > 0) & (wo[..., 2:3] > 0)
        masking = safe_div(2 * cos_h * wo[..., 2:3], wo_h)
        shadowing = safe_div(2 * cos_h * wi[..., 2:3], wo_h)
        value = xp.minimum(xp.minimum(masking, shadowing), xp.ones_like(masking))
        return xp.where(ok, value, xp.zeros_like(value))
    if kind == "smith_separable":
        if wi.shape != wo.shape:
            return distribution.G1(wi, wm) * distribution.G1(wo, wm)
        # Both in one call, stacked on a new leading axis: half the array operations.
        g1 = distribution.G1(xp.stack([wi, wo]), wm)
        return g1[0, ...] * g1[1, ...]
    if kind == "smith_correlated":
        visible = ((dot(wi, wm, keepdims=True) * wi[..., 2:3]) > 0) & (
            (dot(wo, wm, keepdims=True) * wo[..., 2:3]) > 0
        )
        lambda_i = distribution.smith_lambda(wi)
        lambda_o = distribution.smith_lambda(wo)
        reflection = 1 / (1 + lambda_i + lambda_o)
        same_side = (wi[..., 2:3] * wo[..., 2:3]) > 0
        # NumPy, every pair on one side (a BSDF's quadrature above the surface): the
        # reflection form is the value, the Beta function would be taken for nothing
        if not transmission or (is_numpy(xp) and bool(np.all(same_side))):
            return xp.where(visible, reflection, xp.zeros_like(reflection))
        big = constant(1e6, lambda_i)
        li, lo = xp.minimum(lambda_i, big), xp.minimum(lambda_o, big)
        log_beta = log_gamma(1 + li) + log_gamma(1 + lo) - log_gamma(2 + li + lo)
        transmission = xp.exp(xp.minimum(log_beta, xp.zeros_like(log_beta)))
        value = xp.where(same_side, reflection, transmission)
        return xp.where(visible, value, xp.zeros_like(value))
    raise ParameterError(f"masking must be one of {', '.join(MASKINGS)}; got {kind!r}")


# --------------------------------------------------------------------------- Fresnel
def check_material(material: Any) -> str | None:
    """The conductor preset ``material`` names (case-insensitive), or ``None`` for ``None`` and
    ``"none"`` (no preset).

    Raises
    ------
    brdfkit.errors.ParameterError
        For anything but a string or ``None``, or a name not in
        :data:`brdfkit.fresnel.CONDUCTORS`.
    """
    if material is None:
        return None
    known = {name.lower(): name for name in CONDUCTORS}
    if isinstance(material, str) and material.strip().lower() == "none":
        return None
    if not isinstance(material, str) or material.strip().lower() not in known:
        raise ParameterError(
            f"material must be 'none' or a conductor of brdfkit.fresnel.CONDUCTORS "
            f"({', '.join(CONDUCTORS)}); got {type(material).__name__} {material!r:.60}"
        )
    return known[material.strip().lower()]


@dataclass(frozen=True, eq=False)
class FresnelTerm:
    r"""The Fresnel factor :math:`F(\omega\cdot\omega_m)` of a microfacet or smooth model.

    ``kind`` is ``"none"`` (F = 1), ``"dielectric"`` (exact, relative index ``eta`` = n_inside /
    n_outside), ``"conductor"`` (exact, complex index ``eta + i k``; or ``material`` naming a
    preset of :data:`brdfkit.fresnel.CONDUCTORS`, e.g. ``"Au"``) or ``"schlick"`` (reflectance
    ``f0`` at normal incidence). Build it with :meth:`from_options`, which validates: η ∈
    [0.01, 100] (:data:`IOR`), k ∈ [0, 100] (:data:`EXTINCTION`), f0 ∈ [0, 1].

    References
    ----------
    .. [1] M. Born, E. Wolf, *Principles of Optics*, 7th ed., §1.5, §14.2, 1999.
    .. [2] C. Schlick, Computer Graphics Forum 13(3), 1994.
    """

    kind: str = "none"
    eta: Any = 1.5
    k: Any = 0.0
    f0: Any = 0.04

    @classmethod
    def from_options(
        cls,
        kind: str,
        *,
        eta: Any = None,
        k: Any = None,
        f0: Any = None,
        material: str | None = None,
    ) -> FresnelTerm:
        """Validate the Fresnel options of a model and resolve a ``material`` preset.

        Every option given (not ``None``) is checked, whether ``kind`` uses it or not.

        Raises
        ------
        brdfkit.errors.ParameterError
            Naming the bad option (unknown kind, ``eta``, ``k`` or ``f0`` outside its domain or
            no number, unknown material, or a material with a non-conductor kind).
        """
        check_choice("fresnel", kind, FRESNELS)
        for name, value, domain in (("eta", eta, IOR), ("k", k, EXTINCTION), ("f0", f0, ALBEDO)):
            if value is not None:
                domain.check(name, value)
        if check_material(material) is not None:
            if kind != "conductor":
                raise ParameterError(
                    "material names a conductor preset, so fresnel must be 'conductor'; "
                    f"got {kind!r}"
                )
            eta, k = conductor(material)
        return cls(
            kind, 1.5 if eta is None else eta, 0.0 if k is None else k, 0.04 if f0 is None else f0
        )

    @classmethod
    def for_conductor(cls, material: str | None, eta: Any, k: Any) -> FresnelTerm:
        """The Fresnel term of Mitsuba-style conductor options: a ``material`` preset, or the
        complex index ``eta + i k``, or F = 1 for ``material="none"`` with no ``eta``.

        Raises
        ------
        brdfkit.errors.ParameterError
            When both a material and ``eta`` are given, ``k`` without ``eta``, or bad values.
        """
        named = check_material(material) is not None
        if eta is not None and named:
            raise ParameterError(
                f"material and eta are exclusive; got material={material!r} and eta"
            )
        if eta is not None:
            return cls.from_options("conductor", eta=eta, k=k)
        if named:
            return cls.from_options("conductor", material=material)
        if k is not None:
            raise ParameterError("k needs eta (the complex index is eta + i k); got k alone")
        return cls.from_options("none")

    @property
    def channels(self) -> int:
        """The channel count of the Fresnel parameters in use."""
        used = {
            "none": (),
            "dielectric": (self.eta,),
            "conductor": (self.eta, self.k),
            "schlick": (self.f0,),
        }[self.kind]
        return channel_count(*used, names=("eta", "k", "f0")[: len(used)])

    def __call__(self, cos_theta: Array) -> Array:
        """F at the cosine(s) ``cos_theta`` of shape ``(..., 1)``; ``(..., C)``.

        The cosine is clamped to [−1, 1] first: ``wi·h`` of directions that are unit only to
        rounding (or a little off, as user input often is) may exceed 1.

        The Fresnel function runs with the channel axis moved first (``(C, ...)``) and the
        result is moved back, a view with the channels as the slowest axis: NumPy would
        broadcast a ``(..., 1)`` cosine against ``(C,)`` parameters one short channel row at a
        time instead of in whole-batch loops, and ufuncs keep the channel-major layout in what
        is computed from the result.
        """
        xp = namespace(cos_theta)
        cos_theta = clamp(cos_theta, -1.0, 1.0)
        if self.kind == "none":
            return xp.ones_like(cos_theta)
        function, names = {
            "dielectric": (fresnel_dielectric, ("eta",)),
            # eta, k checked in from_options, the cosine clamped above
            "conductor": (functools.partial(fresnel_conductor, validate=False), ("eta", "k")),
            "schlick": (schlick, ("f0",)),
        }[self.kind]
        args = [cos_theta, *(param(getattr(self, name), cos_theta) for name in names)]
        ndim = max(a.ndim for a in args)
        return channels_last(function(*(channels_first(a, ndim) for a in args)))


__all__ = [
    "EXTINCTION",
    "FRESNELS",
    "GAUSSIAN_WIDTH",
    "GGX",
    "IOR",
    "MASKINGS",
    "Beckmann",
    "FresnelTerm",
    "MicrofacetDistribution",
    "TorranceSparrowGaussian",
    "check_material",
    "masking_shadowing",
]
