r"""Microfacet reflection: the BRDF shared by Torrance–Sparrow, Cook–Torrance and the rough
conductor.

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
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, dot, namespace, normalize, safe_div
from brdfkit.brdf._microfacet_sampling import normal_pdf, sample_normal
from brdfkit.brdf.base import ALBEDO, BRDF, Sample, zero_unless
from brdfkit.brdf.microfacet import (
    EXTINCTION,
    GGX,
    IOR,
    MASKINGS,
    Beckmann,
    FresnelTerm,
    MicrofacetDistribution,
    masking_shadowing,
)
from brdfkit.brdf.phong import reflect_about
from brdfkit.errors import ParameterError
from brdfkit.params import Domain, channel_count, check_choice, check_flag

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
    (:func:`~brdfkit.params.check_domains`); the distribution checks the pair it gets.

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

    Subclasses are frozen dataclasses with a field ``masking`` (one of
    :data:`~brdfkit.brdf.microfacet.MASKINGS`) that set, in ``__post_init__``, the attributes
    ``ndf`` (a :class:`~brdfkit.brdf.microfacet.MicrofacetDistribution`), ``fresnel_term``
    (a :class:`~brdfkit.brdf.microfacet.FresnelTerm`), ``visible`` (whether to sample visible
    normals) and the channels they imply, by calling :meth:`_setup`.

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
    choices: ClassVar[dict[str, tuple[str, ...]]] = {"masking": MASKINGS}

    def _channel_values(self) -> dict[str, Any]:
        """None here: the channels follow from the distribution and the Fresnel term, which
        :meth:`_setup` counts."""
        return {}

    def _setup(
        self,
        distribution: MicrofacetDistribution,
        fresnel_term: FresnelTerm,
        visible: bool,
        extra_channels: tuple[Any, ...] = (),
    ) -> None:
        if visible and not distribution.supports_visible_sampling:
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

    def _eval(self, wi: Array, wo: Array) -> Array:
        cos_theta_i, cos_theta_o = wi[..., 2:3], wo[..., 2:3]
        h = normalize(wi + wo)
        d = self.ndf.D(h)
        g = masking_shadowing(self.ndf, wi, wo, h, self.masking, transmission=False)
        f = self.fresnel_term(dot(wi, h, keepdims=True))
        # D G / (4 cos θi cos θo) per pair (unless the roughness is per channel), then F
        return safe_div(d * g, 4 * cos_theta_i * cos_theta_o) * f

    def _pdf(self, wi: Array, wo: Array) -> Array:
        h = normalize(wi + wo)
        wo_h = dot(wo, h)
        # p(ωi) = p(ωh) / (4 ωo·ωh): the Jacobian of reflection about ωh
        p_h = normal_pdf(self.ndf, self.visible, wo, h)
        return zero_unless(wo_h > 0, safe_div(p_h, 4 * wo_h))

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        wi = reflect_about(wo, sample_normal(self.ndf, self.visible, wo, u))
        wi, wo = xp.broadcast_arrays(wi, wo)
        pdf = self.pdf(wi, wo)
        # f·cos θi / p: the unmasked f suffices, the weight is 0 wherever p is (ωi below)
        weight = safe_div(self._eval(wi, wo) * wi[..., 2:3], pdf[..., None])
        return Sample(wi, weight, pdf, False)

    def _sampling_weight(self, wo: Array) -> Array:
        """Grey Fresnel reflectance at ωo's own angle, ``mean_c F(cos θo)``."""
        xp = namespace(wo)
        return xp.mean(self.fresnel_term(xp.abs(wo[..., 2:3])), axis=-1)


FRESNEL_DOMAINS: dict[str, Domain] = {"eta": IOR, "k": EXTINCTION, "f0": ALBEDO}
"""The domains of the Fresnel parameters of Torrance–Sparrow and Cook–Torrance."""


def _fresnel_options(model: Any) -> FresnelTerm:
    """The Fresnel term of a Torrance–Sparrow/Cook–Torrance model's options (conductor when a
    ``material`` is named and no ``fresnel`` kind is given, else dielectric); ``eta``, ``k``
    and ``f0``, never ``None`` here, are checked by :func:`~brdfkit.params.check_domains`
    first."""
    kind = model.fresnel
    if kind is None:
        kind = "conductor" if model.material is not None else "dielectric"
    return FresnelTerm.from_options(
        kind, eta=model.eta, k=model.k, f0=model.f0, material=model.material
    )


__all__ = [
    "DISTRIBUTIONS",
    "MicrofacetReflection",
    "defined_params",
    "stretched_distribution",
]
