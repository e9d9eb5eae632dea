r"""Minnaert's (1941) limb-darkening law for the Moon and planets."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, namespace
from brdfkit.brdf.base import ALBEDO, BRDF, positive_or_one, register, upper_hemisphere
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    channel_mean,
    cosine_lobe_pdf,
    sample_cosine_lobe,
)
from brdfkit.params import Domain, param

MINNAERT_K = Domain(0.0, 10.0, hint="Minnaert exponent k (1: Lambertian)")
"""Minnaert's exponent k: [0, 10]; k = 1 is Lambertian, k = ½ the flat full-Moon disk."""


@register("minnaert")
@dataclass(frozen=True, eq=False)
class Minnaert(MixtureSampled):
    r"""Minnaert (1941): the reciprocal power law :math:`L \propto \mu_0^k\mu^{k-1}`.

    .. math::
        f_r(\omega_i, \omega_o) = \rho\,\frac{k+1}{2\pi}\,(\mu_0\,\mu)^{k-1},
        \qquad \mu_0 = \cos\theta_i,\ \mu = \cos\theta_o,

    normalised so that the albedo at normal view is ρ: the directional albedo is exactly
    :math:`\rho(\mu) = \rho\,\mu^{k-1}`. k = 1 is the Lambertian ρ/π; lit from the camera
    (μ0 = μ) the disk's radiance is :math:`\rho E (k+1)\mu^{2k-1}/(2\pi)`, flat for k = ½ (the
    full Moon, whose fitted k is ≈ 0.5–0.7 at small phase angles) and limb-dark for k > ½.

    **Reciprocal**: yes (symmetric in μ0, μ; Minnaert built it so). **Energy-conserving**: no
    (``energy_conserving = False``): for k < 1 the albedo ρ μ^{k−1} exceeds 1 at grazing view
    (μ < ρ^{1/(1−k)}) and f is unbounded at the horizon; for k ≥ 1 it is ≤ ρ.

    Sampled exactly in proportion to :math:`f\cos\theta_i \propto \mu_0^k`: the cosine-power
    lobe of exponent k about the normal, so ``weight`` = ρ μ^{k−1} (the channel mean of a
    channel-varying k is sampled).

    Parameters
    ----------
    rho : albedo at normal view, in [0, 1] (``allow_unphysical=True``: up to 10⁶).
    exponent : Minnaert's exponent k in [0, 10] (spec strings may call it ``k``).
    Both scalars or per channel.

    References
    ----------
    .. [1] M. Minnaert, "The reciprocity principle in lunar photometry", Astrophysical Journal
           93, 403–410, 1941.
    .. [2] B. Hapke, *Theory of Reflectance and Emittance Spectroscopy*, 2nd ed., 2012, ch. 12.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Minnaert
    >>> f = Minnaert(rho=0.5, exponent=0.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1492])
    >>> np.round(f.albedo(wo), 4)
    array([0.559])
    """

    energy_conserving = False

    rho: Any = 0.5
    exponent: Any = 0.5
    allow_unphysical: bool = False
    spec_aliases: ClassVar[dict[str, str]] = {"k": "exponent"}
    domains: ClassVar[dict[str, Domain]] = {"rho": ALBEDO, "exponent": MINNAERT_K}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(0.3, 0.5),
            cls(0.8, 1.0),
            cls(0.5, 0.7),
            cls(1.0, 2.5),
            cls([0.4, 0.3, 0.2], 0.6),
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        rho, k = param(self.rho, wi), param(self.exponent, wi)
        mu_mu0 = wi[..., 2:3] * wo[..., 2:3]
        # the power of a base ≤ 0 (a masked lane) would be ∞ or NaN: 1 there
        base = xp.where(upper_hemisphere(wi, wo), mu_mu0, xp.ones_like(mu_mu0))
        return rho * (k + 1) / (2 * math.pi) * base ** (k - 1)

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        batch = wo.shape[:-1]
        n = xp.broadcast_to(channel_mean(param(self.exponent, wo)), batch)
        normal = xp.broadcast_to(xp.asarray([0.0, 0.0, 1.0], dtype=wo.dtype), wo.shape)
        return [
            (
                xp.ones_like(wo[..., 2]),
                lambda wi: cosine_lobe_pdf(wi[..., 2], n),
                lambda u: sample_cosine_lobe(normal, n, u),
            )
        ]

    def _albedo(self, wo: Array, hemisphere: str) -> Array:
        r"""Exact: :math:`\rho\,\mu^{k-1}` (nothing is transmitted)."""
        rho, k = param(self.rho, wo), param(self.exponent, wo)
        return rho * positive_or_one(wo[..., 2:3]) ** (k - 1)


__all__ = ["MINNAERT_K", "Minnaert"]
