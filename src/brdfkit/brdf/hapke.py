r"""Hapke's model of particulate (regolith) surfaces, with the opposition surge."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, constant, dot, namespace, norm, safe_div, safe_sqrt
from brdfkit.brdf.base import BRDF, register, upper_hemisphere
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    channel_mean,
    cosine_lobe_pdf,
    diffuse_and_lobe,
    sample_cosine_lobe,
)
from brdfkit.params import Domain, param

ASYMMETRY = Domain(-0.95, 0.95, hint="Henyey–Greenstein asymmetry ξ (< 0: backscattering)")
"""The Henyey–Greenstein asymmetry ξ of the particles: [−0.95, 0.95]."""

SURGE_AMPLITUDE = Domain(0.0, 10.0, hint="opposition-surge amplitude B0")
"""The amplitude B0 of the shadow-hiding opposition surge: [0, 10] (B0 ≤ 1 when the particles
scatter like the regolith's; Hapke 1986 allows more)."""

SURGE_WIDTH = Domain(1e-3, 10.0, hint="opposition-surge width h (radians, about half the HWHM)")
"""The angular width parameter h of the opposition surge: [10⁻³, 10]."""


def henyey_greenstein(cos_g: Array, xi: Array) -> Array:
    r"""The Henyey–Greenstein phase function in the phase angle g (g = 0: back to the source),
    normalised to :math:`\frac{1}{4\pi}\oint p\,d\Omega = 1`:
    :math:`p(g) = \frac{1-\xi^2}{(1 + 2\xi\cos g + \xi^2)^{3/2}}`; ξ < 0 scatters backwards.

    References
    ----------
    .. [1] L. G. Henyey, J. L. Greenstein, "Diffuse radiation in the galaxy", ApJ 93, 1941.
    .. [2] B. Hapke, *Theory of Reflectance and Emittance Spectroscopy*, 2nd ed., 2012, ch. 6.
    """
    xp = namespace(cos_g, xi)
    base = 1 + 2 * xi * cos_g + xi * xi
    return (1 - xi * xi) / (base * xp.sqrt(base))


def chandrasekhar_h(x: Array, w: Array) -> Array:
    r"""Hapke's (2002) approximation of Chandrasekhar's H function for isotropic scattering,

    .. math::
        H(x) \approx \Bigl[1 - w\,x\Bigl(r_0 + \frac{1 - 2r_0x}{2}\ln\frac{1+x}{x}\Bigr)
        \Bigr]^{-1},\qquad r_0 = \frac{1-\gamma}{1+\gamma},\ \gamma = \sqrt{1-w},

    within 1 % of the exact H for every w ∈ [0, 1] and x ∈ [0, 1] (Hapke 2002); H(0) = 1.
    ``x`` ``(..., 1)`` ≥ 0 and ``w`` ``(..., C)`` broadcast.

    References
    ----------
    .. [1] B. Hapke, "Bidirectional reflectance spectroscopy 5. The coherent backscatter
           opposition effect and anisotropic scattering", Icarus 157, 523–534, 2002.
    .. [2] S. Chandrasekhar, *Radiative Transfer*, Oxford, 1950, ch. V.
    """
    xp = namespace(x, w)
    gamma = safe_sqrt(1 - w)
    r0 = (1 - gamma) / (1 + gamma)
    positive = x > 0
    safe_x = xp.where(positive, x, xp.ones_like(x))
    x_log = xp.where(positive, safe_x * (xp.log1p(safe_x) - xp.log(safe_x)), xp.zeros_like(x))
    return 1 / (1 - w * (x * r0 + (1 - 2 * r0 * x) / 2 * x_log))


def tan_half_phase(wi: Array, wo: Array) -> Array:
    r""":math:`\tan(g/2) = |\omega_i - \omega_o| / |\omega_i + \omega_o|` of unit vectors
    (``(..., 1)``), with no trigonometry and a finite gradient at g = 0."""
    diff, total = wi - wo, wi + wo
    return safe_div(safe_sqrt(dot(diff, diff, keepdims=True)), norm(total, keepdims=True))


def opposition_surge(tan_half_g: Array, b0: Array, h: Array) -> Array:
    r"""Hapke's (1986) shadow-hiding opposition effect :math:`B(g) = B_0 / (1 + \tan(g/2)/h)`.

    References
    ----------
    .. [1] B. Hapke, "Bidirectional reflectance spectroscopy 4. The extinction coefficient and
           the opposition effect", Icarus 67, 264–280, 1986.
    """
    return b0 / (1 + tan_half_g / h)


@register("hapke")
@dataclass(frozen=True, eq=False)
class Hapke(MixtureSampled):
    r"""Hapke (1981, 1986): regolith as a half-space of particles, with the opposition surge.

    .. math::
        f_r(\omega_i, \omega_o) = \frac{w}{4\pi}\,\frac{1}{\mu_0 + \mu}
            \Bigl\{\bigl[1 + B(g)\bigr]p(g) + H(\mu_0)H(\mu) - 1\Bigr\},

    with μ0 = cos θi, μ = cos θo, g the phase angle (cos g = ωi·ωo; g = 0 when the light is
    behind the viewer), w the particles' single-scattering albedo, p the Henyey–Greenstein
    phase function (:func:`henyey_greenstein`, asymmetry ξ), B(g) = B0/(1 + tan(g/2)/h) the
    shadow-hiding opposition surge (Hapke 1986; :func:`opposition_surge`) and H the
    multiple-scattering function of isotropic scatterers in Hapke's 2002 approximation
    (:func:`chandrasekhar_h`). This is the bidirectional reflectance r of Hapke (1981)
    with Hapke 1986's B(g), divided by μ0 (r = f μ0). Macroscopic roughness (Hapke 1984's θ̄)
    and the coherent-backscatter surge (2002) are not included. B0 = 0, ξ = 0 and
    :math:`H \equiv 1` give :class:`~brdfkit.brdf.lommel_seeliger.LommelSeeliger`.

    The surge brightens the surface towards the light (retroreflection): the full Moon is
    flat-disked (f μ0 at μ0 = μ, g = 0 is :math:`\frac{w}{8\pi}\{(1+B_0)p(0) + H(\mu)^2 - 1\}`,
    nearly constant for dark w) and much brighter than at quarter phase.

    **Reciprocal**: yes (symmetric in μ0 and μ; g is symmetric). **Energy-conserving**: not
    claimed (``energy_conserving = False``): the surge adds light near g = 0 that Hapke's
    model takes from nowhere, and H is approximate: w = 1, B0 = 0, ξ = 0 reflects 0.986 (θo = 0)
    to 0.991 (θo = 1.5 rad) instead of exactly 1 (tested).

    Sampled by a mixture of the cosine-weighted hemisphere and a cosine-power lobe about
    ``wo`` (the retroreflection peak) whose half-width matches the surge's, chosen with
    probability B0/(2(1 + B0)).

    Parameters
    ----------
    w : single-scattering albedo in [0, 1], scalar or per channel.
    xi : Henyey–Greenstein asymmetry ξ in [−0.95, 0.95] (negative: backscattering particles).
    b0 : surge amplitude B0 in [0, 10].
    h : surge width h in [10⁻³, 10] (the surge falls to half at tan(g/2) = h).

    The defaults (w = 0.25, ξ = −0.25, B0 = 1, h = 0.06) are chosen lunar-like: dark,
    backscattering particles and a narrow surge (compare the fits of Helfenstein & Veverka
    1987; they are not a fit).

    References
    ----------
    .. [1] B. Hapke, "Bidirectional reflectance spectroscopy 1. Theory", Journal of Geophysical
           Research 86(B4), 3039–3054, 1981.
    .. [2] B. Hapke, "Bidirectional reflectance spectroscopy 4. The extinction coefficient and
           the opposition effect", Icarus 67, 264–280, 1986.
    .. [3] B. Hapke, "Bidirectional reflectance spectroscopy 5.", Icarus 157, 523–534, 2002.
    .. [4] P. Helfenstein, J. Veverka, "Photometric properties of lunar terrains derived from
           Hapke's equation", Icarus 72, 342–357, 1987.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Hapke
    >>> f = Hapke()
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0175])
    >>> np.round(f.eval(wo, wo), 4)
    array([0.0577])
    """

    energy_conserving = False

    w: Any = 0.25
    xi: Any = -0.25
    b0: Any = 1.0
    h: Any = 0.06
    spec_aliases: ClassVar[dict[str, str]] = {"single_scattering_albedo": "w"}
    domains: ClassVar[dict[str, Domain]] = {
        "w": Domain(0.0, 1.0, hint="single-scattering albedo"),
        "xi": ASYMMETRY,
        "b0": SURGE_AMPLITUDE,
        "h": SURGE_WIDTH,
    }

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(w=1.0, xi=0.0, b0=0.0),
            cls(w=0.6, xi=0.3, b0=0.5, h=0.2),
            cls(w=[0.3, 0.25, 0.2], xi=-0.4, b0=2.0, h=0.02),
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        w, xi = param(self.w, wi), param(self.xi, wi)
        b0, h = param(self.b0, wi), param(self.h, wi)
        # H(μ) takes log μ: μ0 = μ = 0 on masked lanes, where it is finite
        upper = upper_hemisphere(wi, wo)
        mu_0, mu = wi[..., 2:3], wo[..., 2:3]
        mu_0 = xp.where(upper, mu_0, xp.zeros_like(mu_0))
        mu = xp.where(upper, mu, xp.zeros_like(mu))
        phase = henyey_greenstein(dot(wi, wo, keepdims=True), xi)
        surge = opposition_surge(tan_half_phase(wi, wo), b0, h)
        multiple = chandrasekhar_h(mu_0, w) * chandrasekhar_h(mu, w) - 1
        return safe_div(w / (4 * math.pi) * ((1 + surge) * phase + multiple), mu_0 + mu)

    def _lobe_exponent(self, wo: Array) -> Array:
        r"""The exponent n of the cosⁿ lobe about ``wo`` whose half maximum lies where the
        surge's does, :math:`\cos^n g = 1/2` at :math:`g = 2\arctan h`."""
        xp = namespace(wo)
        h = channel_mean(param(self.h, wo))
        cos_half = xp.cos(2 * xp.atan(xp.minimum(h, constant(1.0, h))))
        return xp.maximum(-math.log(2) / xp.log(xp.maximum(cos_half, constant(1e-3, h))), 1 + 0 * h)

    def components(self, wo: Array) -> list[Component]:
        b0 = channel_mean(param(self.b0, wo))
        surge = b0 / (2 * (1 + b0))
        return diffuse_and_lobe(
            wo,
            1 - surge,
            surge,
            (self._lobe_exponent(wo),),
            lambda wi, n: cosine_lobe_pdf(dot(wi, wo), n),
            lambda u, n: sample_cosine_lobe(wo, n, u),
        )

    def _sampling_weight(self, wo: Array) -> Array:
        return channel_mean(param(self.w, wo))


__all__ = [
    "ASYMMETRY",
    "SURGE_AMPLITUDE",
    "SURGE_WIDTH",
    "Hapke",
    "chandrasekhar_h",
    "henyey_greenstein",
    "opposition_surge",
    "tan_half_phase",
]
