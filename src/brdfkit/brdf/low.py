r"""Löw, Kronander, Ynnerman & Unger's (2012) glossy BRDF models: the ABC microfacet model and
the smooth-surface model, in the parameterisation of their published fits to MERL.

Both use the ABC function :math:`S(x) = A(1 + Bx)^{-C}` of a squared distance x from the
specular configuration, with unnormalised scale A (fitted in sr⁻¹), and the exact dielectric
Fresnel factor of index η (written by Cook & Torrance's form in the paper).

Both are sampled by half vectors from the normalised ABC distribution
:math:`p(h) = \frac{B(C-1)}{2\pi(1-(1+B)^{1-C})}(1 + B(1-\cos\theta_h))^{-C}` (exact inverse
CDF), reflected about h, mixed with 10 % cosine-weighted hemisphere samples.

References
----------
.. [1] J. Löw, J. Kronander, A. Ynnerman, J. Unger, "BRDF models for accurate and efficient
       rendering of glossy surfaces", ACM Transactions on Graphics 31(1), 9:1–14, 2012.
.. [2] P. Peers et al., BRDF benchmark ``bbm``: ``ndf/low.h``, ``bsdfmodel/lowmicrofacet.h``,
       ``bsdfmodel/lowsmooth.h`` (the parameterisation of the published fits).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, dot, namespace, normalize, safe_sqrt
from brdfkit.brdf.base import BRDF, register, upper_hemisphere
from brdfkit.brdf.microfacet import IOR, FresnelTerm, masking_shadowing
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    diffuse_and_lobe,
    reflect_about,
    reflected_pdf,
)
from brdfkit.params import UNPHYSICAL_MAX, Domain, param

LOW_A = Domain(0.0, UNPHYSICAL_MAX, hint="unnormalised scale A in sr⁻¹")
"""Löw's scale A: [0, 10⁶] sr⁻¹ (the MERL fits reach 5.7·10³)."""

LOW_B = Domain(1e-6, 1e9, hint="sharpness B")
"""Löw's sharpness B: [10⁻⁶, 10⁹] (the MERL fits reach 8.1·10⁶)."""

LOW_C = Domain(0.0, 100.0, hint="fall-off exponent C")
"""Löw's fall-off exponent C: [0, 100] (the MERL fits lie in [0.014, 2.7])."""

_CONE = 0.1
"""The share of cosine-weighted samples in the mixture (covers the tails of the lobe)."""


def abc_integral(b: Array, c: Array) -> Array:
    r""":math:`\frac1B\int_0^B (1+t)^{-C}dt = \frac{1-(1+B)^{1-C}}{B(C-1)}` (:math:`\ln(1+B)/B`
    at C = 1): :math:`\int_0^1 (1+B(1-x))^{-C}dx`, the ABC function's mean."""
    xp = namespace(b, c)
    log_1b = xp.log1p(b)
    one = xp.abs(c - 1) < 1e-8
    safe_c = xp.where(one, xp.full_like(c, 2.0), c)
    return xp.where(one, log_1b, -xp.expm1((1 - safe_c) * log_1b) / (safe_c - 1)) / b


def abc_pdf(h: Array, b: Array, c: Array) -> Array:
    r"""Density of :func:`sample_abc` over half vectors, ``(...,)`` (``b``, ``c`` ``(...,)``).

    :math:`p(h) = (1 + B(1-\cos\theta_h))^{-C}\,\frac{B}{2\pi}\,\nu`,
    :math:`\nu = \frac{C-1}{1-(1+B)^{1-C}}` (:math:`1/\ln(1+B)` at C = 1); it integrates to 1
    over the hemisphere. 0 below the surface.
    """
    xp = namespace(h, b, c)
    cos_h = h[..., 2]
    positive = cos_h > 0
    base = 1 + b * (1 - xp.where(positive, cos_h, xp.ones_like(cos_h)))
    value = base ** (-c) / (2 * math.pi * abc_integral(b, c))
    return xp.where(positive, value, xp.zeros_like(value))


def sample_abc(b: Array, c: Array, u: Array) -> Array:
    r"""Half vectors with density :func:`abc_pdf`: with :math:`t = B(1-\cos\theta_h)`,
    :math:`1 + t = (1 + u_1((1+B)^{1-C} - 1))^{1/(1-C)}` (:math:`(1+B)^{u_1}` at C = 1) inverts
    the CDF exactly; :math:`\varphi_h = 2\pi u_2`."""
    xp = namespace(b, c, u)
    log_1b = xp.log1p(b)
    one = xp.abs(c - 1) < 1e-8
    safe_c = xp.where(one, xp.full_like(c, 2.0), c)
    log_1t = xp.where(
        one,
        u[..., 0] * log_1b,
        xp.log1p(u[..., 0] * xp.expm1((1 - safe_c) * log_1b)) / (1 - safe_c),
    )
    cos_theta = xp.clip(1 - xp.expm1(log_1t) / b, -1.0, 1.0)
    sin_theta = safe_sqrt(1 - cos_theta * cos_theta)
    phi = 2 * math.pi * u[..., 1]
    return xp.stack([sin_theta * xp.cos(phi), sin_theta * xp.sin(phi), cos_theta], axis=-1)


def _abc_lobe(wo: Array, b: Any, c: Any, b_scale: float) -> list[Component]:
    """10 % cosine hemisphere, 90 % ABC half vectors (sharpness ``b_scale`` times the channel
    mean of ``b``) reflected about h."""

    def lobe_pdf(wi: Array, b_mean: Array, c_mean: Array) -> Array:
        return reflected_pdf(wi, wo, lambda h: abc_pdf(h, b_scale * b_mean, c_mean))

    def lobe_sample(u: Array, b_mean: Array, c_mean: Array) -> Array:
        return reflect_about(wo, sample_abc(b_scale * b_mean, c_mean, u))

    xp = namespace(wo)
    cone = xp.full_like(wo[..., 0], _CONE)
    return diffuse_and_lobe(wo, cone, 1 - cone, (b, c), lobe_pdf, lobe_sample)


@dataclass(frozen=True, eq=False)
class _ABC(MixtureSampled):
    """The parameters and checks the two ABC models share."""

    energy_conserving = False

    A: Any = 10.0
    B: Any = 1000.0
    C: Any = 1.0
    eta: Any = 1.5
    domains: ClassVar[dict[str, Domain]] = {"A": LOW_A, "B": LOW_B, "C": LOW_C, "eta": IOR}

    sampling_b_scale: ClassVar[float] = 1.0
    """The sampling distribution's sharpness over B."""

    def components(self, wo: Array) -> list[Component]:
        return _abc_lobe(wo, self.B, self.C, self.sampling_b_scale)

    def _albedo_scale(self, like: Array) -> Array:
        """The closed-form albedo near normal incidence over R0 = ((η−1)/(η+1))², ``(..., C)``."""
        raise NotImplementedError

    def _sampling_weight(self, wo: Array) -> Array:
        """The albedo near normal incidence, R0 times :meth:`_albedo_scale`, channel mean."""
        eta = param(self.eta, wo)
        r0 = ((eta - 1) / (eta + 1)) ** 2
        return namespace(wo).mean(r0 * self._albedo_scale(wo), axis=-1)


@register("low_microfacet")
@dataclass(frozen=True, eq=False)
class LowMicrofacet(_ABC):
    r"""Löw et al.'s (2012) ABC microfacet model, as their MERL fits are parameterised.

    .. math::

        f_r = A\,\frac{D(h)\,G(\omega_i,\omega_o,h)\,F(\omega_i\cdot h)}
                      {\pi\cos\theta_i\cos\theta_o},\qquad
        D(h) = (1 + B(1-\cos\theta_h))^{-C}

    with the V-groove G (:func:`~brdfkit.brdf.microfacet.masking_shadowing`) and the exact
    dielectric F of index η. The fits' π is not in the paper's eq. 15 (``bbm``'s
    ``lowmicrofacetfit``: "an additional (incorrect) normalization factor of π" that the
    published parameters carry). **Reciprocal**: yes. **Not energy-conserving**: D is
    unnormalised and A free.

    Parameters
    ----------
    A : scale in [0, 10⁶] sr⁻¹.
    B : sharpness in [10⁻⁶, 10⁹].
    C : exponent in [0, 100].
    eta : relative index of refraction η ∈ [0.01, 100]. All broadcast against ``batch + (C,)``.

    References
    ----------
    .. [1] J. Löw et al., ACM TOG 31(1), 2012, eq. 15.
    .. [2] ``bbm``, ``bsdfmodel/lowmicrofacet.h`` and ``bsdfmodel/low.h``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import LowMicrofacet
    >>> f = LowMicrofacet(A=10.0, B=100.0, C=1.0, eta=1.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0577])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(10.0, 1000.0, 1.0, 1.5),
            cls(50.0, 10000.0, 0.8, 2.2),
            cls(0.5, 20.0, 2.5, 1.1),
            cls([40.0, 30.0, 20.0], 300.0, 1.4, 1.4),
        ]

    def _albedo_scale(self, like: Array) -> Array:
        # ∫ A D G F/(π cos θi cos θo) cos θi dωi ≈ (4A/π)∫D dωh at normal view (dωi ≈ 4 dωh).
        a, b, c = param(self.A, like), param(self.B, like), param(self.C, like)
        return 8 * a * abc_integral(b, c)

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        a, b, c = param(self.A, wi), param(self.B, wi), param(self.C, wi)
        upper = upper_hemisphere(wi, wo)
        h = normalize(wi + wo)
        d = (1 + b * (1 - h[..., 2:3])) ** (-c)
        g = masking_shadowing(None, wi, wo, h, "v_groove")  # type: ignore[arg-type]
        f = FresnelTerm("dielectric", eta=self.eta)(dot(wi, h, keepdims=True))
        # 1/(cos θi cos θo), by 1 on masked lanes
        cos_io = xp.where(upper, wi[..., 2:3] * wo[..., 2:3], xp.ones_like(wi[..., 2:3]))
        return a * d * g * f / (math.pi * cos_io)


@register("low_smooth")
@dataclass(frozen=True, eq=False)
class LowSmooth(_ABC):
    r"""Löw et al.'s (2012) smooth-surface model (their eq. 9 with the ABC S), as fitted.

    .. math::

        f_r = A\,(1 + B\lVert\mathbf i_p + \mathbf o_p\rVert^2)^{-C}\,F(\cos\theta_d),\qquad
        \cos\theta_d = \sqrt{1 - \tfrac14\lVert\mathbf i_p - \mathbf o_p\rVert^2}

    with :math:`\mathbf i_p, \mathbf o_p` the projections of ωi, ωo on the surface plane and
    the exact dielectric F of index η. **Reciprocal**: yes (symmetric in ωi, ωo). **Not
    energy-conserving**: A is free. Sampled as the ABC distribution with sharpness 8B
    (near the mirror direction :math:`\lVert\mathbf i_p+\mathbf o_p\rVert^2 \approx 8(1 -
    \cos\theta_h)`), mixed with the cosine-weighted hemisphere.

    Parameters
    ----------
    A : scale in [0, 10⁶] sr⁻¹.
    B : sharpness in [10⁻⁶, 10⁹].
    C : exponent in [0, 100].
    eta : relative index of refraction η ∈ [0.01, 100].

    References
    ----------
    .. [1] J. Löw et al., ACM TOG 31(1), 2012, §4 (eqs. 9–11).
    .. [2] ``bbm``, ``bsdfmodel/lowsmooth.h``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import LowSmooth
    >>> f = LowSmooth(A=10.0, B=100.0, C=1.0, eta=1.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0279])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(10.0, 1000.0, 1.0, 1.5),
            cls(100.0, 20000.0, 0.7, 1.6),
            cls(1.0, 10.0, 2.0, 1.2),
            cls([60.0, 40.0, 30.0], 500.0, 1.2, 2.0),
        ]

    sampling_b_scale = 8.0

    def _albedo_scale(self, like: Array) -> Array:
        # at normal view: ∫ A (1 + B r²)^(−C) dA over the unit disk of projected ωi.
        a, b, c = param(self.A, like), param(self.B, like), param(self.C, like)
        return math.pi * a * abc_integral(b, c)

    def _eval(self, wi: Array, wo: Array) -> Array:
        a, b, c = param(self.A, wi), param(self.B, wi), param(self.C, wi)
        plus = wi[..., :2] + wo[..., :2]
        minus = wi[..., :2] - wo[..., :2]
        d_p2 = dot(plus, plus, keepdims=True)
        cos_theta_d = safe_sqrt(1 - 0.25 * dot(minus, minus, keepdims=True))
        s = (1 + b * d_p2) ** (-c)
        return a * s * FresnelTerm("dielectric", eta=self.eta)(cos_theta_d)


__all__ = ["LowMicrofacet", "LowSmooth"]
