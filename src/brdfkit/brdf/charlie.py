r"""The Estevez–Kulla (2017) "Charlie" sheen: cloth's soft retro- and grazing highlight."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, asarray, clamp, namespace, normalize, safe_div
from brdfkit.brdf.base import ALBEDO, BRDF, Sample, register
from brdfkit.params import Domain, param
from brdfkit.sampling import square_to_uniform_hemisphere, square_to_uniform_hemisphere_pdf

SHEEN_ROUGHNESS = Domain(1e-3, 1.0, hint="sheen roughness r")
"""The Charlie roughness r: [10⁻³, 1] (the fit of Λ covers r ∈ [0, 1])."""

_LAMBDA_FIT = {  # Estevez & Kulla 2017, Table 1: (a, b, c, d, e) at r = 0 and r = 1
    0.0: (25.3245, 3.32435, 0.16801, -1.27393, -4.85967),
    1.0: (21.5473, 3.82987, 0.19823, -1.97760, -4.32054),
}


def charlie_lambda(cos_theta: Array, r: Array) -> Array:
    r"""Estevez & Kulla's fit to the Smith :math:`\Lambda` of the Charlie distribution:
    :math:`\Lambda(\mu) = e^{L(\mu)}` for μ < 1/2 and :math:`e^{2L(1/2) - L(1 - \mu)}` above,
    :math:`L(x) = a/(1 + bx^c) + dx + e`, the coefficients blended from r = 1 to r = 0 with
    weight :math:`(1 - r)^2`."""
    xp = namespace(cos_theta, r)
    t = (1 - r) ** 2
    a, b, c, d, e = (p1 + (p0 - p1) * t for p0, p1 in zip(*_LAMBDA_FIT.values(), strict=True))

    def fit(x: Array) -> Array:
        return a / (1 + b * x**c) + d * x + e

    mu = clamp(xp.abs(cos_theta), 1e-7, 1.0)
    low = fit(xp.minimum(mu, 0.5 + 0 * mu))
    high = 2 * fit(0.5 + 0 * mu) - fit(xp.maximum(1 - mu, 0 * mu + 1e-7))
    return xp.exp(xp.where(mu < 0.5, low, high))


@register("charlie")
@dataclass(frozen=True, eq=False)
class Charlie(BRDF):
    r"""The Estevez–Kulla (2017) "Charlie" sheen lobe for cloth.

    A microfacet lobe of inverted-Gaussian-like normals that lie mostly near the horizon (the
    fibres' sides), with Fresnel 1 and the sheen colour as its weight:

    .. math::
        f_r = C\,\frac{D(\omega_h)\,G(\omega_i, \omega_o)}{4\cos\theta_i\cos\theta_o},\qquad
        D(\omega_h) = \frac{(2 + 1/r)\sin^{1/r}\theta_h}{2\pi},\qquad
        G = \frac{1}{1 + \Lambda(\cos\theta_i) + \Lambda(\cos\theta_o)},

    with D normalised (:math:`\int D\cos\theta_h\,d\omega_h = 1`) and Λ the paper's fit to the
    distribution's Smith Λ (:func:`charlie_lambda`; glTF's ``KHR_materials_sheen`` uses the
    same with r = roughness²). ``terminator_softening=True`` raises the light's Λ to the power
    :math:`1 + 2(1 - \cos\theta_i)^8`, the paper's softening of the shadow terminator, which
    breaks reciprocity.

    Reciprocal: yes, without terminator softening. Energy-conserving: no — Λ is a fit, and it
    under-shadows grazing views of sharp sheens: the albedo (C = 1) is 0.1–0.9 over most of
    the domain but exceeds 1 near θo → 90° for small r (≈ 1.7 at r = 0.01, θo = 89°;
    ``tests/brdf/test_charlie.py``). The paper does not claim conservation either: it layers
    the lobe over a base scaled by 1 − its tabulated albedo, which this lobe alone does not
    include.

    Sampled uniformly over the hemisphere, as the paper does (the lobe is broad).

    Parameters
    ----------
    color : the sheen colour C ∈ [0, 1] (per channel; default 1).
    roughness : r ∈ [10⁻³, 1] (default 0.5): small r puts the normals at the horizon (a sharp
        grazing sheen), r = 1 gives D ∝ sin θh.
    terminator_softening : the paper's softer terminator (default False).

    References
    ----------
    .. [1] A. C. Estevez, C. Kulla, "Production friendly microfacet sheen BRDF", Sony
           Pictures Imageworks technical report, 2017.
    .. [2] Khronos, glTF ``KHR_materials_sheen`` extension, 2021.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Charlie
    >>> f = Charlie(color=1.0, roughness=0.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0087])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    color: Any = 1.0
    roughness: Any = 0.5
    terminator_softening: bool = False
    energy_conserving: ClassVar[bool] = False
    domains: ClassVar[dict[str, Domain]] = {"color": ALBEDO, "roughness": SHEEN_ROUGHNESS}

    @property
    def reciprocal(self) -> bool:  # type: ignore[override]
        return not self.terminator_softening

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(color=[0.9, 0.4, 0.5], roughness=0.2),
            cls(roughness=1.0),
            cls(color=0.8, roughness=0.05, terminator_softening=True),
        ]

    def D(self, wh: Array) -> Array:
        """The normal distribution, ``(..., C)``; 0 below the surface."""
        xp = namespace(wh)
        r = param(self.roughness, wh)
        sin2 = clamp(1 - wh[..., 2:3] * wh[..., 2:3], 0.0, 1.0)
        value = (2 + 1 / r) * sin2 ** (0.5 / r) / (2 * math.pi)
        return xp.where(wh[..., 2:3] > 0, value, xp.zeros_like(value))

    def _eval(self, wi: Array, wo: Array) -> Array:
        r = param(self.roughness, wi)
        cos_i, cos_o = wi[..., 2:3], wo[..., 2:3]
        lambda_i = charlie_lambda(cos_i, r)
        if self.terminator_softening:
            lambda_i = lambda_i ** (1 + 2 * (1 - clamp(cos_i, 0.0, 1.0)) ** 8)
        g = 1 / (1 + lambda_i + charlie_lambda(cos_o, r))
        d = self.D(normalize(wi + wo))
        return param(self.color, wi) * safe_div(d * g, 4 * cos_i * cos_o)

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return square_to_uniform_hemisphere_pdf(wi)

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        u = asarray(u, xp, like=wo)
        wi = square_to_uniform_hemisphere(u[..., :2])
        wi, wo = xp.broadcast_arrays(wi, wo)
        weight = self.eval(wi, wo) * (wi[..., 2:3] * 2 * math.pi)  # f cos θi / (1/2π)
        return Sample(wi, weight, self.pdf(wi, wo), False)

    def _sampling_weight(self, wo: Array) -> Array:
        """A cheap albedo estimate: 0.3 C̄ (the lobe's albedo is 0.1–0.7)."""
        xp = namespace(wo)
        return 0.3 * xp.mean(param(self.color, wo), axis=-1) + xp.zeros_like(wo[..., 2])


__all__ = ["SHEEN_ROUGHNESS", "Charlie", "charlie_lambda"]
