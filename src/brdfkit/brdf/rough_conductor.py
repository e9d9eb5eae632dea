"""The rough conductor: GGX or Beckmann microfacets with Smith masking and conductor Fresnel.

The spec names ``rough_conductor``, ``ggx`` and ``beckmann`` (Mitsuba 3's ``roughconductor``).

References
----------
.. [1] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
       through rough surfaces", EGSR 2007.
.. [2] E. Heitz, "Understanding the masking-shadowing function in microfacet-based BRDFs",
       JCGT 3(2), 2014.
.. [3] W. Jakob et al., Mitsuba 3, ``src/bsdfs/roughconductor.cpp``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit.brdf.base import (
    BRDF,
    ROUGHNESS,
    register,
)
from brdfkit.brdf.microfacet import (
    EXTINCTION,
    IOR,
    FresnelTerm,
)
from brdfkit.brdf.microfacet_reflection import (
    DISTRIBUTIONS,
    MicrofacetReflection,
    stretched_distribution,
)
from brdfkit.errors import ParameterError
from brdfkit.params import Domain


@register("rough_conductor")
@dataclass(frozen=True, eq=False)
class RoughConductor(MicrofacetReflection):
    r"""A rough metal: GGX or Beckmann microfacets, Smith masking, conductor Fresnel.

    .. math::
        f_r = \frac{D(\omega_h)\,F_c(\omega_i\cdot\omega_h;\ \eta + ik)\,
            G_2(\omega_i,\omega_o,\omega_h)}{4\cos\theta_i\cos\theta_o},

    the Mitsuba 3 ``roughconductor``. The default masking is the height-correlated Smith
    :math:`G_2 = 1/(1+\Lambda(\omega_i)+\Lambda(\omega_o))` (Heitz 2014: the exact G2 of a
    Smith microsurface with uncorrelated slopes and heights); ``masking="smith_separable"``
    (:math:`G_1G_1`) is what Mitsuba 3 evaluates, and with ``distribution="beckmann"``
    Mitsuba's Walter rational G1 needs ``approximate_g1=True`` too.

    Reciprocal: yes. Energy-conserving: yes (albedo ≤ 1; single scattering only, so rough
    surfaces lose energy: GGX α = 1, F = 1 reflects 1 − ln 2 ≈ 0.307 at normal incidence).

    Parameters
    ----------
    alpha : isotropic roughness in [10⁻⁴, 10] (scalar or per channel), or
    alpha_u, alpha_v : anisotropic roughness along the tangent x and bitangent y (both, same
        domain).
    distribution : ``"ggx"`` (default) or ``"beckmann"``.
    material : conductor preset of :data:`brdfkit.fresnel.CONDUCTORS` (``"Au"``, ``"Cu"``, …),
        or ``"none"`` (default, as Mitsuba: F = 1, a perfect reflector) — unless
    eta, k : the complex index η + ik, η ∈ [0.01, 100], k ∈ [0, 100] (per channel allowed), is
        given instead.
    masking : ``"smith_correlated"`` (default), ``"smith_separable"`` or ``"v_groove"``.
    sample_visible : sample visible normals (default True) or D cos θh.
    approximate_g1 : Beckmann only — Walter's rational G1, as Mitsuba (default False).

    References
    ----------
    .. [1] B. Walter et al., EGSR 2007.
    .. [2] E. Heitz, JCGT 3(2), 2014; E. Heitz, JCGT 7(4), 2018.
    .. [3] W. Jakob et al., Mitsuba 3, ``roughconductor``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import RoughConductor
    >>> f = RoughConductor(alpha=0.3, material='Au')
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.5502, 0.4564, 0.1867])
    >>> s = f.sample(wo, np.array([0.5, 0.5]))
    >>> np.round(s.wi, 4), np.round(s.weight, 4)
    (array([0.5028, 0.4682, 0.7266]), array([0.9476, 0.786 , 0.3228]))
    """

    alpha: Any = 0.1
    alpha_u: Any = None
    alpha_v: Any = None
    distribution_name: ClassVar[str | None] = None
    distribution: str = "ggx"
    material: str | None = "none"
    eta: Any = None
    k: Any = None
    masking: str = "smith_correlated"
    sample_visible: bool = True
    approximate_g1: bool = False
    domains: ClassVar[dict[str, Domain]] = {
        "alpha": ROUGHNESS,
        "alpha_u": ROUGHNESS,
        "alpha_v": ROUGHNESS,
        "eta": IOR,
        "k": EXTINCTION,
    }
    choices: ClassVar[dict[str, tuple[str, ...]]] = {"distribution": DISTRIBUTIONS}

    def __post_init__(self) -> None:
        super().__post_init__()
        fixed = type(self).distribution_name
        if fixed is not None and self.distribution != fixed:
            raise ParameterError(
                f"distribution must be {fixed!r} for the {type(self).spec_name!r} model; got "
                f"{self.distribution!r} (use rough_conductor to choose)"
            )
        fresnel = FresnelTerm.for_conductor(self.material, self.eta, self.k)
        dist = stretched_distribution(
            self.distribution, self.alpha, self.alpha_u, self.alpha_v, self.approximate_g1
        )
        self._setup(dist, fresnel, self.sample_visible)

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(alpha=0.05),
            cls(alpha=0.3, material="Au"),
            cls(alpha=1.0),
            cls(alpha_u=0.1, alpha_v=0.4, material="Cu"),
            cls(alpha=0.2, distribution="beckmann", masking="smith_separable"),
        ]


@register("ggx")
@dataclass(frozen=True, eq=False)
class GGXConductor(RoughConductor):
    """:class:`RoughConductor` with the GGX distribution: ``ggx(alpha=0.2, material='Au')``.

    Reciprocal: yes. Energy-conserving: yes (single scattering: the albedo is ≤ 1, less for
    rough surfaces).

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import GGXConductor
    >>> f = GGXConductor(alpha=0.3, material='Au')
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.5502, 0.4564, 0.1867])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    distribution_name: ClassVar[str | None] = "ggx"
    distribution: str = "ggx"

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(alpha=0.2, material="Au"), cls(alpha_u=0.05, alpha_v=0.3)]


@register("beckmann")
@dataclass(frozen=True, eq=False)
class BeckmannConductor(RoughConductor):
    """:class:`RoughConductor` with the Beckmann distribution: ``beckmann(alpha=0.2)``.

    Reciprocal: yes. Energy-conserving: yes (single scattering: the albedo is ≤ 1, less for
    rough surfaces).

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import BeckmannConductor
    >>> f = BeckmannConductor(alpha=0.3)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.825])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    distribution_name: ClassVar[str | None] = "beckmann"
    distribution: str = "beckmann"

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(alpha=0.2, material="Ag"), cls(alpha_u=0.4, alpha_v=0.1)]


__all__ = [
    "BeckmannConductor",
    "GGXConductor",
    "RoughConductor",
]
