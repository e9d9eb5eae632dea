r"""The Oren–Nayar model of rough diffuse surfaces (V-groove Lambertian microfacets)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, namespace, safe_div, safe_sqrt
from brdfkit.brdf.base import ALBEDO, BRDF, register, upper_hemisphere
from brdfkit.brdf.phong import Component, MixtureSampled, channel_mean, cosine_component
from brdfkit.params import Domain, param

_MODELS = ("qualitative", "full")

SIGMA = Domain(0.0, math.pi / 2, hint="slope deviation in radians")
"""The facet slope deviation σ: [0, π/2] radians."""


@register("oren_nayar")
@dataclass(frozen=True, eq=False)
class OrenNayar(MixtureSampled):
    r"""Oren & Nayar (1994): Lambertian V-groove facets with Gaussian slopes of deviation σ.

    ``model="qualitative"`` (the form of the lectures):

    .. math::

        f_r = \frac{\rho}{\pi}\Bigl(A + B\max[0, \cos(\varphi_r-\varphi_i)]\sin\alpha\tan\beta
        \Bigr),\quad A = 1 - 0.5\frac{\sigma^2}{\sigma^2+0.33},\quad
        B = 0.45\frac{\sigma^2}{\sigma^2+0.09}

    ``model="full"`` (the paper's eqs. 25–30: direct term with C1, C2, C3 and the two-bounce
    interreflection term):

    .. math::

        f_r &= \frac{\rho}{\pi}\Bigl[C_1 + \cos\Delta\varphi\,C_2\tan\beta
              + (1-|\cos\Delta\varphi|)\,C_3\tan\tfrac{\alpha+\beta}{2}\Bigr]
              + 0.17\frac{\rho^2}{\pi}\frac{\sigma^2}{\sigma^2+0.13}
              \Bigl[1 - \cos\Delta\varphi\bigl(\tfrac{2\beta}{\pi}\bigr)^2\Bigr],\\
        C_1 &= 1 - 0.5\frac{\sigma^2}{\sigma^2+0.33},\quad
        C_2 = 0.45\frac{\sigma^2}{\sigma^2+0.09}\begin{cases}\sin\alpha & \cos\Delta\varphi\ge0
              \\ \sin\alpha - (2\beta/\pi)^3 & \text{otherwise}\end{cases},\quad
        C_3 = 0.125\frac{\sigma^2}{\sigma^2+0.09}\Bigl(\frac{4\alpha\beta}{\pi^2}\Bigr)^2

    with α = max(θi, θr), β = min(θi, θr), Δφ = φr − φi. σ = 0 gives exactly ρ/π (Lambertian).
    The full model as published is negative for σ ≳ 1 rad at grazing forward-scattering pairs
    (θi, θr → 90°, Δφ → π; down to −0.25 ρ/π for ρ = 0.05, σ = π/2, since the C2 term there is
    negative and the ρ² interreflection term is small); ``eval`` clamps it at 0.

    **Reciprocal**: yes, both forms — every term depends on (θi, θr) only through the symmetric
    α, β and on cos Δφ (tested). **Energy**: not conserving (``energy_conserving = False``).
    With ρ = 1 both forms lose energy at normal incidence (qualitative: albedo 0.78 at
    σ = 0.5, 0.56 at σ = π/2; full: 0.90 and 0.72) but exceed 1 at grazing view for small σ:
    the qualitative model peaks at ≈ 1.015 (σ ≈ 0.2, θr → 90°), the full model, whose
    interreflection term grows with ρ², at ≈ 1.05 (σ ≈ 0.3, θr → 90°) (measured by quadrature
    and Monte Carlo; the tests check the excess).

    Sampled by the cosine-weighted hemisphere; ``sampling_weight`` is the mean ρ.

    Parameters
    ----------
    rho : albedo ρ ∈ [0, 1] (``allow_unphysical=True`` admits ρ up to 10⁶), broadcast against
        ``batch + (C,)``.
    sigma : σ ∈ [0, π/2] radians, the standard deviation of the facet slope angle.
    model : ``"qualitative"`` or ``"full"``.

    References
    ----------
    .. [1] M. Oren, S. K. Nayar, "Generalization of Lambert's reflectance model",
           SIGGRAPH 1994, 239–246.
    .. [2] S. Koppal, Computational Photography lecture, "Oren–Nayar model – final expression".

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import OrenNayar
    >>> f = OrenNayar(rho=0.5, sigma=0.3)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1421])
    >>> np.round(OrenNayar(rho=0.5, sigma=0.0).eval(wi, wo), 4)
    array([0.1592])
    """

    energy_conserving = False

    rho: Any = 0.5
    sigma: Any = 0.3
    model: str = "qualitative"
    allow_unphysical: bool = False

    domains: ClassVar[dict[str, Domain]] = {"rho": ALBEDO, "sigma": SIGMA}
    choices: ClassVar[dict[str, tuple[str, ...]]] = {"model": _MODELS}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(0.8, 0.0),
            cls(0.5, 0.3),
            cls(1.0, 0.6),
            cls(0.9, 0.35, "full"),
            cls([0.8, 0.5, 0.2], 1.2, "full"),
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        rho, sigma = param(self.rho, wi), param(self.sigma, wi)
        sigma2 = sigma * sigma
        cos_theta_i, cos_theta_o = wi[..., 2:3], wo[..., 2:3]
        sin_theta_i = safe_sqrt(1 - cos_theta_i * cos_theta_i)
        sin_theta_o = safe_sqrt(1 - cos_theta_o * cos_theta_o)
        cos_delta_phi = safe_div(
            wi[..., 0:1] * wo[..., 0:1] + wi[..., 1:2] * wo[..., 1:2], sin_theta_i * sin_theta_o
        )
        # α = max θ, β = min θ: sine and cosine are monotonic on [0, π/2].
        sin_alpha = xp.maximum(sin_theta_i, sin_theta_o)
        sin_beta = xp.minimum(sin_theta_i, sin_theta_o)
        cos_beta = xp.maximum(cos_theta_i, cos_theta_o)
        cos_alpha = xp.minimum(cos_theta_i, cos_theta_o)
        # tan β = 0 on masked lanes (where cos β may be ≤ 0)
        upper = upper_hemisphere(wi, wo)
        tan_beta = safe_div(sin_beta, xp.where(upper, cos_beta, xp.zeros_like(cos_beta)))
        if self.model == "qualitative":
            a = 1 - 0.5 * sigma2 / (sigma2 + 0.33)
            b = 0.45 * sigma2 / (sigma2 + 0.09)
            lobe = xp.maximum(cos_delta_phi, xp.zeros_like(cos_delta_phi)) * sin_alpha * tan_beta
            value = rho / math.pi * (a + b * lobe)
        else:
            alpha = xp.atan2(sin_alpha, cos_alpha)
            beta = xp.atan2(sin_beta, cos_beta)
            two_beta_pi = 2 * beta / math.pi
            c1 = 1 - 0.5 * sigma2 / (sigma2 + 0.33)
            c2 = (
                0.45
                * sigma2
                / (sigma2 + 0.09)
                * xp.where(cos_delta_phi >= 0, sin_alpha, sin_alpha - two_beta_pi**3)
            )
            c3 = 0.125 * sigma2 / (sigma2 + 0.09) * (4 * alpha * beta / math.pi**2) ** 2
            tan_mean = xp.tan((alpha + beta) / 2)
            direct = (
                rho
                / math.pi
                * (c1 + cos_delta_phi * c2 * tan_beta + (1 - xp.abs(cos_delta_phi)) * c3 * tan_mean)
            )
            inter = (
                0.17
                * rho
                * rho
                / math.pi
                * sigma2
                / (sigma2 + 0.13)
                * (1 - cos_delta_phi * two_beta_pi**2)
            )
            # The published fit dips below 0 at grazing forward pairs for σ ≳ 1: clamp it.
            value = xp.maximum(direct + inter, xp.zeros_like(direct))
        return value

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        return [cosine_component(xp.ones_like(wo[..., 2]))]

    def _sampling_weight(self, wo: Array) -> Array:
        return channel_mean(param(self.rho, wo))


__all__ = ["OrenNayar"]
