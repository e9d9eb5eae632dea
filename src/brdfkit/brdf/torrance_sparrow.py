"""Torrance–Sparrow (1967) and Cook–Torrance (1982): microfacet reflection plus a Lambertian term.

Both are :class:`~brdfkit.brdf.microfacet_reflection.MicrofacetReflection` with a diffuse
term; see that module for the shared form and its normalisation.

References
----------
.. [1] K. E. Torrance, E. M. Sparrow, "Theory for off-specular reflection from roughened
       surfaces", JOSA 57(9):1105-1114, 1967.
.. [2] R. L. Cook, K. E. Torrance, "A reflectance model for computer graphics", ACM TOG 1(1):
       7-24, 1982.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, to_numpy
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    ROUGHNESS,
    Sample,
    register,
)
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.brdf.microfacet import (
    GAUSSIAN_WIDTH,
    Beckmann,
    TorranceSparrowGaussian,
)
from brdfkit.brdf.microfacet_reflection import (
    FRESNEL_DOMAINS,
    MicrofacetReflection,
    _fresnel_options,
)
from brdfkit.params import Domain


class _WithDiffuse(MicrofacetReflection):
    """A microfacet lobe plus an optional Lambertian base of albedo ``diffuse``.

    With ``diffuse`` = 0 the model is the specular lobe alone; otherwise ``eval``, ``pdf`` and
    ``sample`` are those of ``Lambertian(diffuse) + (this model without diffuse)``, a
    :class:`~brdfkit.brdf.base.Sum` that samples each lobe in proportion to its albedo estimate.
    """

    diffuse: Any
    domains: ClassVar[dict[str, Domain]] = {"diffuse": ALBEDO}

    def _setup_diffuse(self) -> None:
        """The Lambertian mixture, for ``diffuse`` (checked before :meth:`_setup`) not 0."""
        has_diffuse = bool(np.any(to_numpy(self.diffuse) != 0)) or hasattr(
            self.diffuse, "requires_grad"
        )
        mixture = (
            Lambertian(self.diffuse) + dataclasses.replace(self, diffuse=0.0)
            if has_diffuse
            else None
        )
        object.__setattr__(self, "mixture", mixture)

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        # With a diffuse base the two albedos may add beyond 1: measured, not claimed.
        return self.mixture is None

    def _eval(self, wi: Array, wo: Array) -> Array:
        return super()._eval(wi, wo) if self.mixture is None else self.mixture.eval(wi, wo)

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return super()._pdf(wi, wo) if self.mixture is None else self.mixture.pdf(wi, wo)

    def _sample(self, wo: Array, u: Array) -> Sample:
        return super()._sample(wo, u) if self.mixture is None else self.mixture.sample(wo, u)

    def _sampling_weight(self, wo: Array) -> Array:
        if self.mixture is None:
            return super()._sampling_weight(wo)
        return self.mixture.sampling_weight(wo)


@register("torrance_sparrow")
@dataclass(frozen=True, eq=False)
class TorranceSparrow(_WithDiffuse):
    r"""Torrance & Sparrow (1967): Gaussian facet angles, V-groove masking, Fresnel, + diffuse.

    .. math::
        f_r = \frac{\rho_d}{\pi} + \frac{F(\omega_i\cdot\omega_h)\,G(\omega_i,\omega_o)\,
            D(\theta_h)}{4\cos\theta_i\cos\theta_o},\qquad D = c(m)\,e^{-(\theta_h/m)^2},

    with θh = α the angle between the half vector and the normal, c(m) normalising
    :math:`\int D\cos\theta_h\,d\omega = 1`
    (:class:`~brdfkit.brdf.microfacet.TorranceSparrowGaussian`; the lectures'
    :math:`e^{-\alpha^2/2\sigma_\alpha^2}` has m = √2 σα), and the V-groove
    :math:`G = \min(1, 2\cos\theta_h\cos\theta_o/(\omega_o\cdot\omega_h),
    2\cos\theta_h\cos\theta_i/(\omega_o\cdot\omega_h))`. The paper's "a_f" and absorbing
    constants are replaced by the normalised D and the 1/4 Jacobian (module docstring).

    Reciprocal: yes. Energy-conserving: yes without the diffuse term, for F ≤ 1 (the V-groove
    is Heitz's V-cavity, which passes the white furnace); with ``diffuse`` > 0 the albedos
    may add beyond 1 (measured, not claimed).

    Parameters
    ----------
    m : angular roughness in radians, in [10⁻⁴, 10].
    fresnel : ``"dielectric"`` (default; or ``"conductor"`` when ``material`` is given),
        ``"conductor"``, ``"schlick"`` or ``"none"``.
    eta, k : relative index in [0.01, 100] and extinction coefficient in [0, 100], per channel
        allowed.
    f0 : Schlick's normal-incidence reflectance in [0, 1].
    material : a conductor preset of :data:`brdfkit.fresnel.CONDUCTORS` (e.g. ``"Au"``).
    diffuse : Lambertian albedo ρd in [0, 1] (default 0: specular lobe only).
    masking : ``"v_groove"`` (default, the paper's), ``"smith_separable"`` or
        ``"smith_correlated"`` (Smith Λ of the Gaussian, integrated numerically).

    References
    ----------
    .. [1] K. E. Torrance, E. M. Sparrow, JOSA 57(9):1105-1114, 1967.
    .. [2] S. Koppal, Computational Photography lecture, "Torrance–Sparrow model".

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import TorranceSparrow
    >>> f = TorranceSparrow(m=0.2, diffuse=0.3)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1308])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    m: Any = 0.2
    fresnel: str | None = None
    eta: Any = 1.5
    k: Any = 0.0
    f0: Any = 0.04
    material: str | None = None
    diffuse: Any = 0.0
    masking: str = "v_groove"
    domains: ClassVar[dict[str, Domain]] = {"m": GAUSSIAN_WIDTH, **FRESNEL_DOMAINS}

    def __post_init__(self) -> None:
        super().__post_init__()
        self._setup(TorranceSparrowGaussian(self.m), _fresnel_options(self), False, (self.diffuse,))
        self._setup_diffuse()

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(m=0.15),
            cls(m=0.5, diffuse=0.4),
            cls(m=0.3, material="Au"),
            cls(m=0.3, masking="smith_correlated", fresnel="none"),
        ]


@register("cook_torrance")
@dataclass(frozen=True, eq=False)
class CookTorrance(_WithDiffuse):
    r"""Cook & Torrance (1982): Beckmann distribution, V-groove masking, Fresnel, + diffuse.

    .. math::
        f_r = \frac{\rho_d}{\pi} + \frac{D(\omega_h)\,F(\omega_i\cdot\omega_h)\,
            G(\omega_i,\omega_o,\omega_h)}{4\cos\theta_i\cos\theta_o},\qquad
        D = \frac{e^{-\tan^2\theta_h/m^2}}{\pi m^2\cos^4\theta_h},

    with the V-groove G as in :class:`TorranceSparrow`. The paper's
    :math:`F D G/(\pi (n\cdot l)(n\cdot v))` used D without its 1/π: brdfkit uses the
    normalised modern form with 1/4 (module docstring), for which the white furnace holds.
    ``masking="smith_separable"``/``"smith_correlated"`` give the Smith–Beckmann model.
    Sampled with Beckmann visible normals (``sample_visible=True``) or ``D cos θh``.

    Reciprocal: yes. Energy-conserving: yes without the diffuse term (every masking passes
    the white furnace); with ``diffuse`` > 0 measured, not claimed.

    Parameters
    ----------
    m : rms slope of the facets (Beckmann α), in [10⁻⁴, 10].
    fresnel, eta, k, f0, material, diffuse : as :class:`TorranceSparrow`.
    masking : ``"v_groove"`` (default), ``"smith_separable"`` or ``"smith_correlated"``.
    sample_visible : sample visible normals (default True).

    References
    ----------
    .. [1] R. L. Cook, K. E. Torrance, ACM TOG 1(1):7-24, 1982.
    .. [2] J. Křivánek, Computer Graphics III lecture, "Microfacet theory".

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import CookTorrance
    >>> f = CookTorrance(m=0.3, diffuse=0.3)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1309])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    m: Any = 0.3
    fresnel: str | None = None
    eta: Any = 1.5
    k: Any = 0.0
    f0: Any = 0.04
    material: str | None = None
    diffuse: Any = 0.0
    masking: str = "v_groove"
    sample_visible: bool = True
    domains: ClassVar[dict[str, Domain]] = {"m": ROUGHNESS, **FRESNEL_DOMAINS}

    def __post_init__(self) -> None:
        super().__post_init__()
        self._setup(Beckmann(self.m), _fresnel_options(self), self.sample_visible, (self.diffuse,))
        self._setup_diffuse()

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(m=0.1),
            cls(m=0.4, diffuse=[0.5, 0.3, 0.2]),
            cls(m=0.3, material="Cu"),
            cls(m=0.6, masking="smith_correlated", fresnel="none"),
        ]


__all__ = [
    "CookTorrance",
    "TorranceSparrow",
]
