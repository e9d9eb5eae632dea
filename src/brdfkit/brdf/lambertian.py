"""The Lambertian (ideal diffuse) BRDF."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, namespace
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    Sample,
    check_hemisphere,
    register,
    result_shape,
    upper_hemisphere,
)
from brdfkit.params import Domain, channel_count, check_domains, param
from brdfkit.sampling import square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf


@register("lambertian")
@dataclass(frozen=True, eq=False)
class Lambertian(BRDF):
    r"""Ideal diffuse reflection: :math:`f_r(\omega_i, \omega_o) = \rho / \pi`.

    Reciprocal: yes. Energy-conserving: yes for ρ ≤ 1 (the albedo is exactly ρ at every ``wo``).
    Sampled by the cosine-weighted hemisphere, so ``weight = ρ`` exactly.

    Parameters
    ----------
    rho : the albedo ρ ∈ [0, 1], scalar, per channel (``[r, g, b]``) or a per-pixel texture
        ``(..., C)``. ``allow_unphysical=True`` admits ρ up to 10⁶. Spec strings may call it
        ``albedo`` (``"lambertian(albedo=0.8)"``); the field is ``rho`` because ``albedo`` is
        the protocol's method.

    References
    ----------
    .. [1] J. H. Lambert, *Photometria*, 1760.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §9.2.
    """

    rho: Any = 0.5
    allow_unphysical: bool = False
    spec_aliases: ClassVar[dict[str, str]] = {"albedo": "rho"}
    domains: ClassVar[dict[str, Domain]] = {"rho": ALBEDO}

    def __post_init__(self) -> None:
        check_domains(self)
        object.__setattr__(self, "channels", channel_count(self.rho, names=("rho",)))

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(0.0), cls(0.5), cls(1.0), cls([0.8, 0.5, 0.2])]

    def eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        rho = param(self.rho, wi)
        value = xp.broadcast_to(rho / math.pi, (*result_shape(wi, wo), rho.shape[-1]))
        return xp.where(upper_hemisphere(wi, wo), value, xp.zeros_like(value))

    def pdf(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        p = square_to_cosine_hemisphere_pdf(wi)
        return xp.where(wo[..., 2] > 0, p, xp.zeros_like(p))

    def sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        wi = square_to_cosine_hemisphere(u[..., :2])
        pdf = square_to_cosine_hemisphere_pdf(wi)
        rho = param(self.rho, wo)
        ok = ((wo[..., 2] > 0) & (pdf > 0))[..., None]
        weight = xp.broadcast_to(rho, (*result_shape(wi, wo), rho.shape[-1]))
        weight = xp.where(ok, weight, xp.zeros_like(weight))
        pdf = xp.where(ok[..., 0], pdf, xp.zeros_like(pdf))
        return Sample(wi, weight, pdf, xp.zeros_like(pdf, dtype=xp.bool))

    def albedo_estimate(
        self, wo: Array, samples: int = 0, seed: int = 0, hemisphere: str = "upper"
    ) -> tuple[Array, Array]:
        """Exact: ρ(wo) = ρ for wo above the surface, with zero error (nothing is transmitted,
        so either ``hemisphere`` gives the same)."""
        check_hemisphere(hemisphere)
        xp = namespace(wo)
        rho = param(self.rho, wo)
        value = xp.broadcast_to(rho, (*wo.shape[:-1], rho.shape[-1]))
        value = xp.where((wo[..., 2] > 0)[..., None], value, xp.zeros_like(value))
        return value, xp.zeros_like(value)

    def sampling_weight(self, wo: Array) -> Array:
        xp = namespace(wo)
        return xp.mean(self.albedo_estimate(wo)[0], axis=-1)


__all__ = ["Lambertian"]
