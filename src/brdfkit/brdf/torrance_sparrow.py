r"""Microfacet reflection models: Torrance–Sparrow, Cook–Torrance and the rough conductor.

All share the microfacet BRDF of a height field of mirror facets (Walter et al. 2007, eq. 20),

.. math::
    f_r(\omega_i, \omega_o) = \frac{D(\omega_h)\,F(\omega_i\cdot\omega_h)\,
        G(\omega_i, \omega_o, \omega_h)}{4\cos\theta_i\cos\theta_o},
    \qquad \omega_h = \frac{\omega_i + \omega_o}{\lVert\omega_i + \omega_o\rVert},

the form the lectures write (Koppal, Křivánek). The 1/4 is the Jacobian
:math:`d\omega_h/d\omega_i = 1/(4\,\omega_i\cdot\omega_h)` of reflection about ωh with D
normalised by :math:`\int D\cos\theta_h\,d\omega_h = 1`; it is what makes the white furnace
hold (albedo → 1 for F = 1 and a smooth surface). Cook & Torrance (1982) wrote
:math:`R = F D G / (\pi (n\cdot l)(n\cdot v))` with a Beckmann D *without* its 1/π, i.e. the
normalised D and no 1/4: four times too bright. Torrance & Sparrow (1967) derived the same
:math:`1/(4\cos\theta_i\cos\theta_o)` geometry with an unnormalised Gaussian (the constant
absorbed in their coefficient). brdfkit uses the modern normalised 1/4 form throughout.

Sampling draws ωh (visible normals from ωo where the distribution allows, else
:math:`D\cos\theta_h`), reflects ωo about it, and returns the exact density
:math:`p(\omega_i) = p(\omega_h)/(4\,\omega_o\cdot\omega_h)`; ``weight = f cos θi / pdf``.
A channel-varying roughness is sampled with its channel mean.

References
----------
.. [1] K. E. Torrance, E. M. Sparrow, "Theory for off-specular reflection from roughened
       surfaces", JOSA 57(9):1105-1114, 1967.
.. [2] R. L. Cook, K. E. Torrance, "A reflectance model for computer graphics", ACM TOG 1(1):
       7-24, 1982.
.. [3] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
       through rough surfaces", EGSR 2007.
.. [4] E. Heitz, "Understanding the masking-shadowing function in microfacet-based BRDFs",
       JCGT 3(2), 2014.
.. [5] W. Jakob et al., Mitsuba 3, ``src/bsdfs/roughconductor.cpp``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, constant, dot, namespace, normalize, safe_div, to_numpy
from brdfkit.brdf._microfacet_sampling import normal_pdf, sample_normal
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    ROUGHNESS,
    Domain,
    Sample,
    channel_count,
    check_choice,
    check_domains,
    check_flag,
    register,
    result_shape,
    upper_hemisphere,
)
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.brdf.microfacet import (
    EXTINCTION,
    GAUSSIAN_WIDTH,
    GGX,
    IOR,
    MASKINGS,
    Beckmann,
    FresnelTerm,
    MicrofacetDistribution,
    TorranceSparrowGaussian,
    masking_shadowing,
)
from brdfkit.brdf.phong import reflect_about
from brdfkit.errors import ParameterError

DISTRIBUTIONS = ("ggx", "beckmann")
"""Distributions of :class:`RoughConductor` (and :class:`~brdfkit.brdf.RoughDielectric`)."""


def defined_params(model: Any) -> dict[str, Any]:
    """A model's dataclass fields by name, leaving out those that are ``None`` (unset options)."""
    return {
        f.name: getattr(model, f.name)
        for f in dataclasses.fields(model)
        if getattr(model, f.name) is not None
    }


def stretched_distribution(
    name: str, alpha: Any, alpha_u: Any, alpha_v: Any, approximate_g1: bool
) -> GGX | Beckmann:
    """The GGX or Beckmann distribution of a model's roughness options.

    ``alpha`` gives an isotropic roughness; ``alpha_u`` and ``alpha_v`` (both, along the
    tangent x and the bitangent y, as in Mitsuba 3) an anisotropic one and take precedence.
    The model has checked each roughness against :data:`~brdfkit.brdf.base.ROUGHNESS`
    (:func:`~brdfkit.brdf.base.check_domains`); the distribution checks the pair it gets.

    Raises
    ------
    brdfkit.errors.ParameterError
        For an unknown ``name``, or only one of ``alpha_u``/``alpha_v``.
    """
    check_choice("distribution", name, DISTRIBUTIONS)
    check_flag("approximate_g1", approximate_g1)
    if (alpha_u is None) != (alpha_v is None):
        raise ParameterError(
            "alpha_u and alpha_v must be given together (anisotropic roughness); got "
            f"alpha_u={alpha_u!r:.60}, alpha_v={alpha_v!r:.60}"
        )
    if alpha_u is None:
        alpha_u = alpha_v = alpha
    if name == "ggx":
        return GGX(alpha_u, alpha_v)
    return Beckmann(alpha_u, alpha_v, approximate_g1=approximate_g1)


class MicrofacetReflection(BRDF):
    r"""The microfacet BRDF :math:`D F G / (4\cos\theta_i\cos\theta_o)` (module docstring).

    Subclasses are frozen dataclasses that set, in ``__post_init__``, the attributes
    ``ndf`` (a :class:`~brdfkit.brdf.microfacet.MicrofacetDistribution`), ``fresnel_term``
    (a :class:`~brdfkit.brdf.microfacet.FresnelTerm`), ``masking`` (a field, one of
    :data:`~brdfkit.brdf.microfacet.MASKINGS`) and ``visible`` (whether to sample visible
    normals), by calling :meth:`_setup`.

    Reciprocal: yes (D, G and F(ωi·ωh) = F(ωo·ωh) are symmetric). Energy-conserving for F ≤ 1
    with every masking: G2 ≤ G1(ωo), and the weak white-furnace identity
    :math:`\int G_1(\omega_o,\omega_h) D\langle\omega_o\cdot\omega_h\rangle d\omega_h =
    \cos\theta_o` holds for Smith's G1 and for the V-groove (V-cavity, Heitz 2014 §5.3) G1,
    so the albedo is at most 1 (less: single scattering loses the interreflected energy).
    """

    ndf: MicrofacetDistribution
    fresnel_term: FresnelTerm
    visible: bool
    masking: str

    def _setup(
        self,
        distribution: MicrofacetDistribution,
        fresnel_term: FresnelTerm,
        visible: bool,
        extra_channels: tuple[Any, ...] = (),
    ) -> None:
        check_choice("masking", self.masking, MASKINGS)
        if check_flag("sample_visible", visible) and not distribution.supports_visible_sampling:
            raise ParameterError(
                f"sample_visible must be False for the {type(distribution).__name__} "
                "distribution (it has no visible-normal sampler); got True"
            )
        roughness = [
            getattr(distribution, f.name)
            for f in dataclasses.fields(distribution)
            if f.name in ("alpha_x", "alpha_y", "m")
        ]
        channels = channel_count(
            *roughness,
            np.zeros(fresnel_term.channels),
            *extra_channels,
            names=(
                *("roughness",) * len(roughness),
                "Fresnel parameters",
                *("diffuse",) * len(extra_channels),
            ),
        )
        object.__setattr__(self, "ndf", distribution)
        object.__setattr__(self, "fresnel_term", fresnel_term)
        object.__setattr__(self, "visible", visible)
        object.__setattr__(self, "channels", channels)

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.ndf.isotropic

    def params(self) -> dict[str, Any]:
        return defined_params(self)

    def _specular_eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        cos_i, cos_o = wi[..., 2:3], wo[..., 2:3]
        h = normalize(wi + wo)
        d = self.ndf.D(h)
        g = masking_shadowing(self.ndf, wi, wo, h, self.masking, transmission=False)
        f = self.fresnel_term(dot(wi, h, keepdims=True))
        # D G / (4 cos θi cos θo) and the hemisphere test first: per pair, unless the
        # roughness is per channel; F (finite, in [0, 1]) multiplies once at the end.
        dg = safe_div(d * g, 4 * cos_i * cos_o)
        dg = xp.where(upper_hemisphere(wi, wo), dg, constant(0, dg))
        value = dg * f
        shape = np.broadcast_shapes(value.shape, (*result_shape(wi, wo), self.channels))
        return value if value.shape == shape else xp.broadcast_to(value, shape)

    def _specular_pdf(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        h = normalize(wi + wo)
        p_h = normal_pdf(self.ndf, self.visible, wo, h)
        wo_h = dot(wo, h)
        value = safe_div(p_h, 4 * wo_h)
        ok = (wi[..., 2] > 0) & (wo[..., 2] > 0) & (wo_h > 0)
        return xp.where(ok, value, xp.zeros_like(value))

    def _specular_sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        h = sample_normal(self.ndf, self.visible, wo, u)
        wi = reflect_about(wo, h)
        wi, wo_b = xp.broadcast_arrays(wi, wo)
        pdf = self._specular_pdf(wi, wo_b)
        f = self._specular_eval(wi, wo_b)
        ok = (pdf > 0)[..., None]
        weight = xp.where(ok, safe_div(f * wi[..., 2:3], pdf[..., None]), xp.zeros_like(f))
        return Sample(wi, weight, pdf, xp.zeros_like(pdf, dtype=xp.bool))

    def eval(self, wi: Array, wo: Array) -> Array:
        return self._specular_eval(wi, wo)

    def pdf(self, wi: Array, wo: Array) -> Array:
        return self._specular_pdf(wi, wo)

    def sample(self, wo: Array, u: Array) -> Sample:
        return self._specular_sample(wo, u)

    def sampling_weight(self, wo: Array) -> Array:
        """Grey Fresnel reflectance at ωo's own angle, ``mean_c F(cos θo)`` (0 below)."""
        xp = namespace(wo)
        cos_o = wo[..., 2:3]
        value = xp.mean(self.fresnel_term(xp.abs(cos_o)), axis=-1)
        return xp.where(cos_o[..., 0] > 0, value, xp.zeros_like(value))


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

    def eval(self, wi: Array, wo: Array) -> Array:
        return self._specular_eval(wi, wo) if self.mixture is None else self.mixture.eval(wi, wo)

    def pdf(self, wi: Array, wo: Array) -> Array:
        return self._specular_pdf(wi, wo) if self.mixture is None else self.mixture.pdf(wi, wo)

    def sample(self, wo: Array, u: Array) -> Sample:
        return self._specular_sample(wo, u) if self.mixture is None else self.mixture.sample(wo, u)

    def sampling_weight(self, wo: Array) -> Array:
        if self.mixture is None:
            return super().sampling_weight(wo)
        return self.mixture.sampling_weight(wo)


FRESNEL_DOMAINS: dict[str, Domain] = {"eta": IOR, "k": EXTINCTION, "f0": ALBEDO}
"""The domains of the Fresnel parameters of Torrance–Sparrow and Cook–Torrance."""


def _fresnel_options(model: Any) -> FresnelTerm:
    """The Fresnel term of a Torrance–Sparrow/Cook–Torrance model's options (conductor when a
    ``material`` is named and no ``fresnel`` kind is given, else dielectric); ``eta``, ``k``
    and ``f0``, never ``None`` here, are checked by :func:`~brdfkit.brdf.base.check_domains`
    first."""
    kind = model.fresnel
    if kind is None:
        kind = "conductor" if model.material is not None else "dielectric"
    return FresnelTerm.from_options(
        kind, eta=model.eta, k=model.k, f0=model.f0, material=model.material
    )


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
        check_domains(self)
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
        check_domains(self)
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

    def __post_init__(self) -> None:
        check_domains(self)
        fixed = type(self).distribution_name
        check_choice("distribution", self.distribution, DISTRIBUTIONS)
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
    """:class:`RoughConductor` with the GGX distribution: ``ggx(alpha=0.2, material='Au')``."""

    distribution_name: ClassVar[str | None] = "ggx"
    distribution: str = "ggx"

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(alpha=0.2, material="Au"), cls(alpha_u=0.05, alpha_v=0.3)]


@register("beckmann")
@dataclass(frozen=True, eq=False)
class BeckmannConductor(RoughConductor):
    """:class:`RoughConductor` with the Beckmann distribution: ``beckmann(alpha=0.2)``."""

    distribution_name: ClassVar[str | None] = "beckmann"
    distribution: str = "beckmann"

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(alpha=0.2, material="Ag"), cls(alpha_u=0.4, alpha_v=0.1)]


__all__ = [
    "DISTRIBUTIONS",
    "BeckmannConductor",
    "CookTorrance",
    "GGXConductor",
    "MicrofacetReflection",
    "RoughConductor",
    "TorranceSparrow",
    "defined_params",
    "stretched_distribution",
]
