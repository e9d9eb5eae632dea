"""The Lambertian (ideal diffuse) BRDF."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array
from brdfkit.brdf.base import ALBEDO, BRDF, Sample, register
from brdfkit.params import Domain, param
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

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> f = Lambertian(rho=0.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1592])
    >>> np.round(f.albedo(wo), 4)
    array([0.5])
    """

    rho: Any = 0.5
    allow_unphysical: bool = False
    spec_aliases: ClassVar[dict[str, str]] = {"albedo": "rho"}
    domains: ClassVar[dict[str, Domain]] = {"rho": ALBEDO}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(0.0), cls(0.5), cls(1.0), cls([0.8, 0.5, 0.2])]

    def _eval(self, wi: Array, wo: Array) -> Array:
        return param(self.rho, wi) / math.pi

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return square_to_cosine_hemisphere_pdf(wi)

    def _sample(self, wo: Array, u: Array) -> Sample:
        wi = square_to_cosine_hemisphere(u[..., :2])
        return Sample(wi, param(self.rho, wo), square_to_cosine_hemisphere_pdf(wi), False)

    def _albedo(self, wo: Array, hemisphere: str) -> Array:
        """Exact: ρ(wo) = ρ (nothing is transmitted, so either ``hemisphere`` gives the same)."""
        return param(self.rho, wo)


__all__ = ["Lambertian"]
