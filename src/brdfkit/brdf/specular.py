r"""Smooth (delta) reflectors and refractors: the ideal mirror, smooth conductor and dielectric.

A perfectly smooth interface scatters into single directions: the mirror direction
:math:`\omega_r = (-\omega_{o,x}, -\omega_{o,y}, \omega_{o,z})` and, for a dielectric, the
refracted direction of Snell's law :math:`\eta_i\sin\theta_i = \eta_t\sin\theta_t`. Their BRDFs
are Dirac deltas (Křivánek's lecture),

.. math::
    f_r(\omega_i, \omega_o) = R(\theta_o)\,\frac{\delta(\cos\theta_i - \cos\theta_o)\,
        \delta(\phi_i - \phi_o \pm \pi)}{\cos\theta_i},

so ``eval`` and ``pdf`` are 0 (a delta has no density) and only ``sample`` sees them, with
``delta=True`` and ``pdf=0``. The sample ``weight`` is the Monte Carlo throughput
:math:`\int f\cos\theta_i\,d\omega_i` of the chosen lobe divided by the probability of
choosing it: R for a mirror; for a dielectric the lobe is chosen with probability F (reflect)
or 1 − F (refract), so the weight is 1 for reflection and the radiance scaling
:math:`(\eta_o/\eta_i)^2` for refraction (see :class:`SmoothDielectric`). The albedo is exact:
R(θo) — the Fresnel reflectance at the viewing angle.

References
----------
.. [1] M. Born, E. Wolf, *Principles of Optics*, 7th ed., §1.5, 1999.
.. [2] E. Veach, *Robust Monte Carlo Methods for Light Transport Simulation*, PhD thesis,
       Stanford, 1997, §5.2 (non-symmetric scattering due to refraction).
.. [3] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §9.3-9.5.
.. [4] W. Jakob et al., Mitsuba 3, ``src/bsdfs/conductor.cpp``, ``dielectric.cpp``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, namespace
from brdfkit.brdf.base import ALBEDO, BRDF, Sample, register
from brdfkit.brdf.microfacet import EXTINCTION, IOR, FresnelTerm
from brdfkit.brdf.microfacet_reflection import defined_params
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel
from brdfkit.params import Domain, channel_count, check_choice, param

MODES = ("radiance", "importance")
"""Transport modes of the dielectric BSDFs (which way the η² factor of refraction goes)."""


def check_mode(mode: Any) -> None:
    """Raise :class:`~brdfkit.errors.ParameterError` unless ``mode`` is one of :data:`MODES`."""
    check_choice("mode", mode, MODES)


def check_scalar_eta(eta: Any) -> None:
    """Raise :class:`~brdfkit.errors.ParameterError` unless a dielectric's relative index,
    already checked against :data:`~brdfkit.brdf.microfacet.IOR`, has one value per point (no
    dispersion)."""
    if channel_count(eta, names=("eta",)) != 1:
        raise ParameterError(
            f"eta must have one value per point (a dispersive index would split the refracted "
            f"ray per channel); got shape {np.shape(np.asarray(eta))}"
        )


def interface_sampling_weight(wo: Array) -> Array:
    """Lobe weight of a dielectric interface: 1 wherever ωo is not grazing (all light is
    reflected or transmitted), ``(...,)``."""
    xp = namespace(wo)
    return xp.where(wo[..., 2] != 0, xp.ones_like(wo[..., 2]), xp.zeros_like(wo[..., 2]))


def _mirror(wo: Array) -> Array:
    xp = namespace(wo)
    return xp.stack([-wo[..., 0], -wo[..., 1], wo[..., 2]], axis=-1)


class _DeltaReflection(BRDF):
    """A one-sided delta reflector of reflectance ``reflectance · F(cos θo)``.

    Subclasses have the field ``reflectance`` and set ``fresnel_term`` and the channels (via
    :meth:`_setup`) in ``__post_init__``.
    """

    has_delta = True
    fresnel_term: FresnelTerm
    reflectance: Any
    domains: ClassVar[dict[str, Domain]] = {"reflectance": ALBEDO}

    def _setup(self, fresnel_term: FresnelTerm) -> None:
        object.__setattr__(self, "fresnel_term", fresnel_term)
        object.__setattr__(
            self,
            "channels",
            channel_count(
                self.reflectance,
                np.zeros(fresnel_term.channels),
                names=("reflectance", "Fresnel parameters"),
            ),
        )

    def _channel_values(self) -> dict[str, Any]:
        """None here: the channels follow from the reflectance and the Fresnel term, which
        :meth:`_setup` counts."""
        return {}

    def params(self) -> dict[str, Any]:
        return defined_params(self)

    def _eval(self, wi: Array, wo: Array) -> Array:
        return namespace(wi).zeros_like(param(self.reflectance, wi))  # a delta: no density

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return namespace(wi).zeros_like(wi[..., 2])

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo = xp.broadcast_to(wo, (*batch, 3))
        return Sample(_mirror(wo), self._albedo(wo, "upper"), xp.zeros_like(wo[..., 2]), True)

    def _albedo(self, wo: Array, hemisphere: str) -> Array:
        """Exact: ρ(ωo) = R·F(cos θo) (nothing is transmitted)."""
        return param(self.reflectance, wo) * self.fresnel_term(namespace(wo).abs(wo[..., 2:3]))


@register("mirror")
@dataclass(frozen=True, eq=False)
class Mirror(_DeltaReflection):
    r"""The ideal mirror: :math:`f_r = R\,F(\theta_o)\,\delta_{\omega_r}(\omega_i)/\cos\theta_i`.

    Reflects into :math:`\omega_r = (-\omega_{o,x}, -\omega_{o,y}, \omega_{o,z})` with
    reflectance ``reflectance`` × F, where F is 1 (``fresnel="none"``, default: a constant
    specular albedo), an exact dielectric (``eta``) or conductor (``eta``, ``k`` or
    ``material='Au'`` …) Fresnel term, or Schlick's (``f0``).

    Reciprocal: yes (the delta is symmetric and F(θi) = F(θo) on it). Energy-conserving: yes
    (albedo = R·F ≤ 1).

    Parameters
    ----------
    reflectance : constant specular albedo in [0, 1] (scalar or per channel).
    fresnel : ``"none"`` (default; ``"conductor"`` when ``material`` is given),
        ``"dielectric"``, ``"conductor"`` or ``"schlick"``.
    eta, k, f0, material : the Fresnel parameters: η ∈ [0.01, 100], k ∈ [0, 100], f0 ∈ [0, 1],
        a conductor preset (see :class:`~brdfkit.brdf.microfacet.FresnelTerm`).

    References
    ----------
    .. [1] J. Křivánek, Computer Graphics III lecture, "BRDF of the ideal mirror".
    .. [2] M. Born, E. Wolf, *Principles of Optics*, 7th ed., §1.5, 1999.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Mirror
    >>> f = Mirror(reflectance=0.9)
    >>> s = f.sample(np.array([-0.48, -0.36, 0.8]), np.array([0.5, 0.5]))
    >>> s.wi, s.weight, bool(s.delta)
    (array([0.48, 0.36, 0.8 ]), array([0.9]), True)
    """

    reflectance: Any = 1.0
    fresnel: str | None = None
    eta: Any = None
    k: Any = None
    f0: Any = None
    material: str | None = None
    domains: ClassVar[dict[str, Domain]] = {"eta": IOR, "k": EXTINCTION, "f0": ALBEDO}

    def __post_init__(self) -> None:
        super().__post_init__()
        kind = self.fresnel
        if kind is None:
            kind = "conductor" if self.material is not None else "none"
        self._setup(
            FresnelTerm.from_options(
                kind, eta=self.eta, k=self.k, f0=self.f0, material=self.material
            )
        )

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(reflectance=[0.9, 0.6, 0.3]),
            cls(fresnel="dielectric", eta=1.5),
            cls(material="Au"),
            cls(fresnel="schlick", f0=0.3),
        ]


@register("smooth_conductor")
@dataclass(frozen=True, eq=False)
class SmoothConductor(_DeltaReflection):
    r"""A polished metal (Mitsuba 3 ``conductor``): a mirror with the conductor Fresnel term.

    :math:`R = s\,F_c(\cos\theta_o;\ \eta + ik)` with the exact conductor reflectance
    (:func:`brdfkit.fresnel.fresnel_conductor`) of a preset ``material`` or of ``eta``, ``k``.

    Reciprocal: yes. Energy-conserving: yes (F ≤ 1, s ≤ 1).

    Parameters
    ----------
    material : conductor preset (``"Au"``, ``"Ag"``, ``"Cu"``, ``"Al"``, ``"Cr"``, ``"W"``), or
        ``"none"`` (default, as Mitsuba: F = 1) — unless
    eta, k : the complex index η + ik, η ∈ [0.01, 100], k ∈ [0, 100] (per channel allowed), is
        given instead.
    reflectance : an extra specular scale s in [0, 1] (Mitsuba's ``specular_reflectance``).

    References
    ----------
    .. [1] M. Born, E. Wolf, *Principles of Optics*, 7th ed., §14.2, 1999.
    .. [2] W. Jakob et al., Mitsuba 3, ``conductor``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import SmoothConductor
    >>> f = SmoothConductor(material='Au')
    >>> n = np.array([0.0, 0.0, 1.0])
    >>> np.round(f.albedo(n), 4)
    array([0.9667, 0.802 , 0.3241])
    >>> f.eval(n, n)
    array([0., 0., 0.])
    """

    material: str | None = "none"
    eta: Any = None
    k: Any = None
    reflectance: Any = 1.0
    domains: ClassVar[dict[str, Domain]] = {"eta": IOR, "k": EXTINCTION}

    def __post_init__(self) -> None:
        super().__post_init__()
        term = FresnelTerm.for_conductor(self.material, self.eta, self.k)
        self._setup(term)

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(), cls(material="Au"), cls(eta=[0.2, 0.9, 1.1], k=[3.9, 2.4, 2.1])]


@register("smooth_dielectric")
@dataclass(frozen=True, eq=False)
class SmoothDielectric(BRDF):
    r"""A smooth interface between two dielectrics (glass, water): delta reflection + refraction.

    From ωo with :math:`\cos\theta_o` on either side, Fresnel's unpolarised
    :math:`F = F(\cos\theta_o; \eta)` is reflected into the mirror direction and
    :math:`1 - F` refracted into :math:`\omega_t = (-\eta_{ti}\omega_{o,x},
    -\eta_{ti}\omega_{o,y}, \cos\theta_t)` (Snell; ``η_ti = 1/η`` from outside, η from
    inside; total internal reflection gives F = 1). Radiance crossing into a medium of index
    :math:`\eta_o` from one of index :math:`\eta_i` is scaled by :math:`(\eta_o/\eta_i)^2`
    (the lecture's :math:`L_o = L_i\,\eta_o^2/\eta_i^2`: the solid angle is compressed), so in
    ``mode="radiance"`` (default, the transport of radiance from lights to the viewer, as
    Mitsuba's eval) a refracted sample has throughput :math:`(1 - F)\,\eta_{ti}^2`, where
    :math:`\eta_{ti}` is the index on ωo's side over the index on the far side;
    ``mode="importance"`` (adjoint transport, light tracing) omits the factor.

    ``sample`` chooses reflection when ``u[..., 0] < F`` (probability F), else refraction, so
    the weights are 1 and :math:`\eta_{ti}^2` (radiance) — unbiased for ``F`` and ``(1 − F)``.

    Reciprocal: no — refraction obeys the generalised reciprocity
    :math:`f(\omega_i\to\omega_o)/\eta_o^2 = f(\omega_o\to\omega_i)/\eta_i^2` (Veach 1997 §5.2);
    the reflection part alone is reciprocal. Energy-conserving: yes — the reflectance F ≤ 1 and
    F + (1 − F) = 1 of the flux; the radiance factor η² is a change of solid angle, not energy.

    Parameters
    ----------
    eta : relative index n_inside / n_outside in [0.01, 100] (1.5 for glass in air), one per
        point.
    mode : ``"radiance"`` (default) or ``"importance"``.

    References
    ----------
    .. [1] M. Born, E. Wolf, *Principles of Optics*, 7th ed., §1.5, 1999.
    .. [2] J. Křivánek, Computer Graphics III lecture, "Change of radiance", "Snell's law".
    .. [3] E. Veach, PhD thesis, Stanford, 1997, §5.2.
    .. [4] W. Jakob et al., Mitsuba 3, ``dielectric``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import SmoothDielectric
    >>> f = SmoothDielectric(eta=1.5, mode='importance')
    >>> n = np.array([0.0, 0.0, 1.0])
    >>> np.round(f.albedo(n), 4)
    array([0.04])
    >>> np.round(f.albedo_estimate(n, hemisphere='both')[0], 4)
    array([1.])
    """

    eta: Any = 1.5
    mode: str = "radiance"

    has_delta = True
    transmits = True
    reciprocal = False
    domains: ClassVar[dict[str, Domain]] = {"eta": IOR}
    choices: ClassVar[dict[str, tuple[str, ...]]] = {"mode": MODES}

    def __post_init__(self) -> None:
        super().__post_init__()
        check_scalar_eta(self.eta)

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(), cls(eta=1.33), cls(eta=2.419, mode="importance"), cls(eta=1 / 1.5)]

    def _eval(self, wi: Array, wo: Array) -> Array:
        return namespace(wi).zeros_like(param(self.eta, wi))  # deltas: no density

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return namespace(wi).zeros_like(wi[..., 2])

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo = xp.broadcast_to(wo, (*batch, 3))
        eta = param(self.eta, wo)
        cos_o = wo[..., 2:3]
        f, cos_t, _, eta_ti = fresnel(cos_o, eta)
        reflect = (u[..., 0:1] < f) | (f >= 1)  # total internal reflection whatever u
        refracted = xp.concat([-eta_ti * wo[..., 0:1], -eta_ti * wo[..., 1:2], cos_t], axis=-1)
        wi = xp.where(reflect, _mirror(wo), refracted)
        scale = self._transmission_scale(eta_ti)
        weight = xp.where(reflect, xp.ones_like(scale), scale)
        weight = xp.where(cos_o != 0, weight, xp.zeros_like(weight))
        return Sample(wi, weight, xp.zeros(batch, dtype=wi.dtype), True)

    def sample_one_sided(self, wo: Array, u: Array) -> Sample:
        r""":meth:`sample` restricted to the upper hemisphere (``wi.z > 0``, where the lights
        of a one-sided render are): from outside the mirror direction with probability 1 and
        weight F (instead of probability F and weight 1), from inside the refracted direction
        with weight :math:`(1 - F)\,s` (0 under total internal reflection). The same
        expectation over the upper hemisphere, with no sample wasted below it: exact.
        """
        xp = namespace(wo, u)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo = xp.broadcast_to(wo, (*batch, 3))
        cos_o = wo[..., 2:3]
        f, cos_t, _, eta_ti = fresnel(cos_o, param(self.eta, wo))
        reflect = cos_o > 0
        refracted = xp.concat([-eta_ti * wo[..., 0:1], -eta_ti * wo[..., 1:2], cos_t], axis=-1)
        wi = xp.where(reflect, _mirror(wo), refracted)
        weight = xp.where(reflect, f, (1 - f) * self._transmission_scale(eta_ti))
        weight = xp.where(wi[..., 2:3] > 0, weight, xp.zeros_like(weight))
        return Sample(wi, weight, xp.zeros(batch, dtype=wi.dtype), xp.ones(batch, dtype=xp.bool))

    def pdf_one_sided(self, wi: Array, wo: Array) -> Array:
        """The density of :meth:`sample_one_sided`: 0 (a delta)."""
        return self.pdf(wi, wo)

    def _transmission_scale(self, eta_ti: Array) -> Array:
        """Weight of a refracted sample: η_ti² in radiance mode (solid angle compressed), or 1."""
        return eta_ti * eta_ti if self.mode == "radiance" else namespace(eta_ti).ones_like(eta_ti)

    def _albedo(self, wo: Array, hemisphere: str) -> Array:
        r"""Exact: the reflectance back into ωo's hemisphere, F(|cos θo|; η) (1 under TIR);
        with ``hemisphere="both"`` plus the transmitted part, :math:`F + (1 - F)\,s` with
        :math:`s = \eta_{ti}^2` in radiance mode, 1 in importance mode (the sample weights).
        """
        xp = namespace(wo)
        f, _, _, eta_ti = fresnel(wo[..., 2:3], param(self.eta, wo))
        value = f
        if hemisphere == "both":
            value = f + (1 - f) * self._transmission_scale(eta_ti)
        return xp.where(wo[..., 2:3] != 0, value, xp.zeros_like(value))

    def _sampling_weight(self, wo: Array) -> Array:
        return interface_sampling_weight(wo)


__all__ = [
    "MODES",
    "Mirror",
    "SmoothConductor",
    "SmoothDielectric",
    "check_mode",
    "check_scalar_eta",
    "interface_sampling_weight",
]
