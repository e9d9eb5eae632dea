r"""Bagher, Soler & Holzschuch's (2012) microfacet BRDF with the Shifted Gamma Distribution
(SGD), in the parameterisation of their published fits to MERL."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, clamp, dot, namespace, normalize, to_numpy
from brdfkit.brdf.base import BRDF, register, upper_hemisphere
from brdfkit.brdf.microfacet import GGX
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    cosine_component,
    reflect_about,
    reflected_pdf,
)
from brdfkit.params import UNPHYSICAL_MAX, Domain, param

SGD_ALPHA = Domain(1e-6, 10.0, hint="SGD width α")
SGD_P = Domain(0.0, 10.0, hint="SGD shape p")
SGD_F = Domain(-10.0, 10.0, hint="Bagher's Fresnel coefficient")
SGD_ANGLE = Domain(-10.0, 10.0, hint="onset angle in radians")
SGD_LARGE = Domain(0.0, 1e300, hint="fitted coefficient (the MERL fits reach 1.6e109)")
_CONE = 0.1  # share of cosine-weighted samples


def _albedo_estimate(mean: dict[str, float]) -> float:
    r"""Albedo near normal incidence for scalar parameters: with dωi ≈ 4 dωh, G ≈ 1 and
    small slopes, :math:`\rho \approx k_s F(1)\frac4\pi\,\alpha\,\Gamma(1-p, \alpha)`
    (:math:`\int P_{22}\,d^2s = \pi\alpha\int_\alpha^\infty e^{-t}t^{-p}dt`)."""
    from scipy.integrate import quad

    alpha, p = mean["alpha"], mean["p"]
    tail, _ = quad(lambda t: math.exp(-t) * t ** (-p), alpha, math.inf, limit=200)
    fresnel = max(mean["f0"] - mean["f1"], 0.0)
    return mean["ks"] * fresnel * 4 / math.pi * alpha * tail


@register("bagher_sgd")
@dataclass(frozen=True, eq=False)
class BagherSGD(MixtureSampled):
    r"""Microfacet BRDF with the Shifted Gamma Distribution (Bagher et al. 2012), as fitted.

    .. math::

        f_r = k_s\frac{D(h)\,G_1(\omega_i)G_1(\omega_o)\,F(\omega_i\cdot h)}
                      {\pi\cos\theta_i\cos\theta_o},\qquad
        D = \frac{P_{22}(\tan^2\theta_h)}{\pi\cos^4\theta_h},\quad
        P_{22}(x) = \frac{e^{-(\alpha + x/\alpha)}}{(\alpha + x/\alpha)^p}

    with the paper's fitted masking :math:`G_1(\omega) = 1 + \Lambda(1 - e^{c(\theta-\theta_0)^k})`
    for θ > θ0 (1 below) and Fresnel :math:`F(c) = F_0 + (1-F_0)(1-c)^5 - F_1 c`, every
    parameter per channel. G1 and F are clamped at 0 where these fitted forms go negative
    (near grazing for some fits), so that f ≥ 0; elsewhere this is ``bbm``'s formula exactly
    (``bagher.h``, ``ndf/sgd.h``, with its extra π of ``microfacet_n::Cook``).
    The fits' scale ("albedo") and D's normalisation K multiply: k_s is their product.
    **Reciprocal**: yes. **Not energy-conserving**: k_s and the fitted G1 are free.

    Sampled by GGX half vectors (D cos θh) with α_GGX = √(mean α) (the SGD's tail
    e^{-tan²θh/α} is Beckmann's with m² = α), reflected about h, mixed with 10 %
    cosine-weighted samples.

    Parameters
    ----------
    ks : scale, the fits' "albedo" times K, [0, 10⁶].
    alpha : SGD width α ∈ [10⁻⁶, 10].
    p : SGD shape ∈ [0, 10].
    f0, f1 : Fresnel coefficients ∈ [−10, 10].
    lam, c : G1's Λ and c ∈ [0, 10³⁰⁰] (``bbm``'s ``Lambda``, ``c``).
    power : G1's exponent (``bbm``'s ``k``) ∈ [0, 10⁶].
    theta0 : G1's onset angle θ0 in radians ∈ [−10, 10].

    References
    ----------
    .. [1] M. M. Bagher, C. Soler, N. Holzschuch, "Accurate fitting of measured reflectances
           using a Shifted Gamma micro-facet distribution", Computer Graphics Forum 31(4),
           1509–1518, 2012.
    .. [2] P. Peers et al., BRDF benchmark ``bbm``: ``bsdfmodel/bagher.h``, ``ndf/sgd.h``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import BagherSGD
    >>> f = BagherSGD()
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0031])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    energy_conserving = False

    ks: Any = 10.0
    alpha: Any = 0.02
    p: Any = 0.5
    f0: Any = 0.05
    f1: Any = 0.0
    lam: Any = 1.0
    c: Any = 1e-6
    power: Any = 20.0
    theta0: Any = 0.5

    domains: ClassVar[dict[str, Domain]] = {
        "ks": Domain(0.0, UNPHYSICAL_MAX, hint="scale"),
        "alpha": SGD_ALPHA,
        "p": SGD_P,
        "f0": SGD_F,
        "f1": SGD_F,
        "lam": SGD_LARGE,
        "c": SGD_LARGE,
        "power": Domain(0.0, UNPHYSICAL_MAX, hint="exponent"),
        "theta0": SGD_ANGLE,
    }

    def __post_init__(self) -> None:
        super().__post_init__()
        mean = {
            n: float(np.mean(to_numpy(getattr(self, n)).astype(np.float64))) for n in self.domains
        }
        object.__setattr__(self, "_sampler", GGX(math.sqrt(mean["alpha"])))
        object.__setattr__(self, "_weight", _albedo_estimate(mean))

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(40.0, 0.005, 0.3, 0.9, 0.0, 2.0, 1e-7, 40.0, 0.2),
            cls(4.0, 0.2, 1.2, 0.04, 0.01, 0.5, 1e-3, 8.0, 0.8),
            cls(
                [1.86, 16.2, 4.0],
                [0.015, 0.03, 0.05],
                [0.46, 0.45, 0.53],
                [6.06, 0.236, 0.58],
                [5.06, 0.18, 0.48],
                [2.6, 2.97, 2.78],
                [1.1e-7, 1.1e-7, 5.3e-8],
                [47.8, 36.3, 31.6],
                [0.21, 0.066, -0.066],
            ),
        ]

    def _g1(self, w: Array, wm: Array) -> Array:
        """The fitted masking G1(ω), clamped at 0; 0 where ω·h ≤ 0 or ω below. ``(..., C)``."""
        xp = namespace(w, wm)
        names = ("lam", "c", "power", "theta0")
        lam, c, k, theta0 = (param(getattr(self, n), w) for n in names)
        theta = xp.acos(clamp(w[..., 2:3], -1.0, 1.0))
        above = theta > theta0
        x = xp.where(above, theta - theta0, xp.ones_like(theta - theta0))
        # 1 + Λ(1 − e^{c xᵏ}) = 1 − Λ expm1(c xᵏ). An exponent capped at half the log of the
        # largest float leaves G1 negative (clamped to 0 below) for any Λ > its inverse.
        cap = 0.5 * math.log(xp.finfo(w.dtype).max)
        growth = xp.expm1(xp.minimum(c * x**k, xp.full_like(c * x, cap)))
        g1 = 1 - lam * xp.where(growth > 0, growth, xp.ones_like(growth))
        g = xp.where(above & (growth > 0), g1, xp.ones_like(g1))
        visible = (w[..., 2:3] > 0) & (dot(w, wm, keepdims=True) > 0)
        return xp.where(visible, xp.maximum(g, xp.zeros_like(g)), xp.zeros_like(g))

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        names = ("ks", "alpha", "p", "f0", "f1")
        ks, alpha, p, f0, f1 = (param(getattr(self, n), wi) for n in names)
        upper = upper_hemisphere(wi, wo)
        h = normalize(wi + wo)
        cos_h = h[..., 2:3]
        # D and the 1/(cos θi cos θo) divide by cosines: by 1 on masked lanes
        cos2 = xp.where(upper & (cos_h > 0), cos_h * cos_h, xp.ones_like(cos_h))
        tan2 = (h[..., 0:1] ** 2 + h[..., 1:2] ** 2) / cos2
        temp = alpha + tan2 / alpha
        d = xp.exp(-temp) / temp**p / (math.pi * cos2 * cos2)
        cos_d = clamp((dot(wi, h, keepdims=True) + dot(wo, h, keepdims=True)) / 2, 0.0, 1.0)
        m = 1 - cos_d
        fresnel = f0 + (1 - f0) * (m * m) * (m * m) * m - f1 * cos_d
        fresnel = xp.maximum(fresnel, xp.zeros_like(fresnel))
        g = self._g1(wi, h) * self._g1(wo, h)
        cos_io = xp.where(upper, wi[..., 2:3] * wo[..., 2:3], xp.ones_like(cos_h))
        return ks * d * g * fresnel / (math.pi * cos_io)

    def _sampling_weight(self, wo: Array) -> Array:
        """A closed-form estimate of the albedo near normal incidence (from the parameters'
        means, :func:`_albedo_estimate`), the same at every ``wo`` above the surface."""
        return namespace(wo).full_like(wo[..., 2], self._weight)

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        cone = xp.full_like(wo[..., 0], _CONE)
        ggx = self._sampler
        return [
            cosine_component(cone),
            (
                1 - cone,
                lambda wi: reflected_pdf(wi, wo, ggx.pdf),
                lambda u: reflect_about(wo, ggx.sample(u)),
            ),
        ]


__all__ = ["BagherSGD"]
