r"""The rough dielectric BSDF of Walter et al. (2007): microfacet reflection and refraction.

A rough interface between air (outside, z > 0) and a dielectric of relative index
η = n_inside / n_outside scatters light both back (BRDF) and through (BTDF). With
:math:`\eta_o, \eta_i` the indices on the sides of ωo (the viewer) and ωi (the light),

.. math::
    f_r &= \frac{F(\omega_o\cdot\omega_h)\,D(\omega_h)\,G(\omega_i,\omega_o,\omega_h)}
              {4\,|\cos\theta_i|\,|\cos\theta_o|},
          \qquad \omega_h = \pm\frac{\omega_i + \omega_o}{\lVert\omega_i + \omega_o\rVert},\\
    f_t &= \frac{|\omega_i\cdot\omega_h|\,|\omega_o\cdot\omega_h|}
              {|\cos\theta_i|\,|\cos\theta_o|}\,
          \frac{\eta_o^2\,(1 - F(\omega_o\cdot\omega_h))\,D(\omega_h)\,
                G(\omega_i,\omega_o,\omega_h)}
              {(\eta_i\,\omega_i\cdot\omega_h + \eta_o\,\omega_o\cdot\omega_h)^2},
          \qquad \omega_h = \pm\frac{\eta_i\omega_i + \eta_o\omega_o}
              {\lVert\eta_i\omega_i + \eta_o\omega_o\rVert},

(Walter et al. eqs. 20-21, the generalised half vector eq. 16 oriented to +z), i.e. Walter's
BTDF with the light direction as its "incident" one. This is the BTDF for *radiance*
(``mode="radiance"``, default): it equals Mitsuba 3's ``roughdielectric`` evaluated in
``TransportMode::Radiance``, which includes the :math:`(\eta_o/\eta_i)^2` solid-angle
compression of radiance missing in Walter's paper. ``mode="importance"`` multiplies
:math:`f_t` by :math:`(\eta_i/\eta_o)^2` (adjoint transport: Walter's formula with the viewer
as incident direction). Masking is Smith's, separable :math:`G_1G_1` (default, Walter's and
Mitsuba's) or height-correlated (:func:`~brdfkit.brdf.microfacet.masking_shadowing`).

Sampling (Walter §5.3 with visible normals, Heitz & d'Eon 2014): draw ωh from the normals
visible from ωo, reflect with probability F(ωo·ωh) else refract; the density is
:math:`p(\omega_h)\,F/(4|\omega_i\cdot\omega_h|)` or
:math:`p(\omega_h)(1-F)\,\eta_i^2|\omega_i\cdot\omega_h| /
(\eta_o\,\omega_o\cdot\omega_h + \eta_i\,\omega_i\cdot\omega_h)^2`. Three uniforms are needed.
A one-sided render (lights above the surface only) uses :meth:`RoughDielectric.sample_one_sided`
instead (:mod:`brdfkit.brdf.one_sided`): the lobe into the upper hemisphere with probability 1,
its density without the factor F (or 1 − F), which moves into the weight.

References
----------
.. [1] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
       through rough surfaces", EGSR 2007.
.. [2] E. Heitz, E. d'Eon, "Importance sampling microfacet-based BSDFs using the distribution
       of visible normals", EGSR 2014.
.. [3] E. Veach, PhD thesis, Stanford, 1997, §5.2.
.. [4] W. Jakob et al., Mitsuba 3, ``src/bsdfs/roughdielectric.cpp``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, dot, namespace, normalize, safe_div
from brdfkit.brdf._microfacet_sampling import normal_pdf, sample_normal
from brdfkit.brdf.base import BRDF, ROUGHNESS, Sample, register, zero_unless
from brdfkit.brdf.microfacet import IOR, masking_shadowing
from brdfkit.brdf.microfacet_reflection import (
    DISTRIBUTIONS,
    defined_params,
    stretched_distribution,
)
from brdfkit.brdf.specular import MODES, check_scalar_eta, interface_sampling_weight
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel
from brdfkit.params import Domain, param

SMITH_MASKINGS = ("smith_separable", "smith_correlated")
"""Masking–shadowing functions defined for transmission."""


@register("rough_dielectric")
@dataclass(frozen=True, eq=False)
class RoughDielectric(BRDF):
    r"""Rough glass: Walter et al. (2007) microfacet reflection + refraction (module docstring).

    Reciprocal: no — the transmission obeys the generalised reciprocity
    :math:`f(\omega_i,\omega_o)/\eta_o^2 = f(\omega_o,\omega_i)/\eta_i^2` (radiance mode; the
    reflection part alone is reciprocal). Energy-conserving: yes — in importance mode (flux)
    the reflected plus transmitted albedo is ≤ 1 (< 1: single scattering); the reflection-only
    albedo that :meth:`albedo` reports is ≤ F ≤ 1 in either mode.

    Parameters
    ----------
    alpha : isotropic roughness in [10⁻⁴, 10] (scalar or per channel), or
    alpha_u, alpha_v : anisotropic roughness along the tangent x and bitangent y (both, same
        domain).
    distribution : ``"ggx"`` (default) or ``"beckmann"``.
    eta : relative index n_inside / n_outside in [0.01, 100] (one per point; 1.5 for glass).
    masking : ``"smith_separable"`` (default, as Walter and Mitsuba) or ``"smith_correlated"``.
    sample_visible : sample visible normals (default True) or D cos θh.
    mode : ``"radiance"`` (default) or ``"importance"`` (the η² factor, see module docstring).
    approximate_g1 : Beckmann only — Walter's rational G1, as Mitsuba (default False).

    References
    ----------
    .. [1] B. Walter et al., EGSR 2007.
    .. [2] W. Jakob et al., Mitsuba 3, ``roughdielectric``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import RoughDielectric
    >>> f = RoughDielectric(alpha=0.1, eta=1.5)
    >>> wo = np.array([0.0, 0.0, 1.0])
    >>> np.round(f.eval(np.array([0.0, 0.0, 1.0]), wo), 4)
    array([0.3183])
    >>> np.round(f.eval(np.array([0.0, 0.0, -1.0]), wo), 4)
    array([122.231])
    """

    alpha: Any = 0.1
    alpha_u: Any = None
    alpha_v: Any = None
    distribution: str = "ggx"
    eta: Any = 1.5
    masking: str = "smith_separable"
    sample_visible: bool = True
    mode: str = "radiance"
    approximate_g1: bool = False

    transmits = True
    reciprocal = False
    domains: ClassVar[dict[str, Domain]] = {
        "alpha": ROUGHNESS,
        "alpha_u": ROUGHNESS,
        "alpha_v": ROUGHNESS,
        "eta": IOR,
    }
    choices: ClassVar[dict[str, tuple[str, ...]]] = {
        "distribution": DISTRIBUTIONS,
        "masking": SMITH_MASKINGS,  # defined for transmission
        "mode": MODES,
    }

    def __post_init__(self) -> None:
        super().__post_init__()
        ndf = stretched_distribution(
            self.distribution, self.alpha, self.alpha_u, self.alpha_v, self.approximate_g1
        )
        check_scalar_eta(self.eta)
        object.__setattr__(self, "ndf", ndf)

    def _channel_values(self) -> dict[str, Any]:
        """The roughness in use: ``alpha_u`` and ``alpha_v`` where given, else ``alpha``."""
        if self.alpha_u is None and self.alpha_v is None:
            return {"alpha": self.alpha}
        return {"alpha_u": self.alpha_u, "alpha_v": self.alpha_v}

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.ndf.isotropic

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(alpha=0.1),
            cls(alpha=0.5, eta=1.33),
            cls(alpha_u=0.1, alpha_v=0.4, distribution="beckmann"),
            cls(alpha=0.3, eta=1 / 1.5, masking="smith_correlated", mode="importance"),
        ]

    def params(self) -> dict[str, Any]:
        return defined_params(self)

    def _geometry(self, wi: Array, wo: Array) -> tuple[Array, ...]:
        """Half vector, side masks and the relative index η_i/η_o of a pair."""
        xp = namespace(wi, wo)
        cos_i, cos_o = wi[..., 2:3], wo[..., 2:3]
        eta = param(self.eta, wi)
        reflect = (cos_i * cos_o) > 0
        eta_rel = xp.where(cos_o > 0, eta, 1 / eta)  # η_i/η_o for a transmission pair
        h = normalize(wo + wi * xp.where(reflect, xp.ones_like(eta_rel), eta_rel))
        h = xp.where(h[..., 2:3] < 0, -h, h)
        valid = (
            (cos_i != 0)
            & (cos_o != 0)
            & (dot(wo, h, keepdims=True) * cos_o > 0)
            & (dot(wi, h, keepdims=True) * cos_i > 0)
        )
        return h, reflect, eta_rel, valid

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        h, reflect, eta_rel, valid = self._geometry(wi, wo)
        cos_i, cos_o = xp.abs(wi[..., 2:3]), xp.abs(wo[..., 2:3])
        wo_h, wi_h = dot(wo, h, keepdims=True), dot(wi, h, keepdims=True)
        d = self.ndf.D(h)
        g = masking_shadowing(self.ndf, wi, wo, h, self.masking)
        f = fresnel(wo_h, param(self.eta, wi))[0]
        reflection = safe_div(f * d * g, 4 * cos_i * cos_o)
        denom = wo_h + eta_rel * wi_h
        transmission = safe_div((1 - f) * d * g * xp.abs(wi_h * wo_h), cos_i * cos_o * denom**2)
        if self.mode == "importance":
            transmission = transmission * eta_rel**2
        return zero_unless(valid, xp.where(reflect, reflection, transmission))

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return self._lobe_pdf(wi, wo, one_sided=False)

    def pdf_one_sided(self, wi: Array, wo: Array) -> Array:
        """The density of :meth:`sample_one_sided`: the chosen lobe's without its probability
        (F or 1 − F), 0 below the surface."""
        return self._lobe_pdf(wi, wo, one_sided=True)

    def _lobe_pdf(self, wi: Array, wo: Array, one_sided: bool) -> Array:
        """The density of reflection chosen with probability F and refraction with 1 − F, or
        (``one_sided``) of the lobe into the upper hemisphere chosen with probability 1."""
        xp = namespace(wi, wo)
        h, reflect, eta_rel, valid = self._geometry(wi, wo)
        wo_h, wi_h = dot(wo, h, keepdims=True), dot(wi, h, keepdims=True)
        p_h = normal_pdf(self.ndf, self.sample_visible, wo, h)[..., None]
        f = fresnel(wo_h, param(self.eta, wi))[0]
        # one-sided: reflection from outside, refraction from inside, each with probability 1
        # (refraction only where the microfacet does not reflect totally)
        p_r = xp.ones_like(f) if one_sided else f
        p_t = xp.astype(f < 1, f.dtype) if one_sided else 1 - f
        jacobian_r = safe_div(p_r, 4 * xp.abs(wi_h))
        jacobian_t = safe_div(p_t * eta_rel**2 * xp.abs(wi_h), (wo_h + eta_rel * wi_h) ** 2)
        value = p_h * xp.where(reflect, jacobian_r, jacobian_t)
        if one_sided:
            valid = valid & (wi[..., 2:3] > 0)
        return xp.where(valid, value, xp.zeros_like(value))[..., 0]

    def _sample(self, wo: Array, u: Array) -> Sample:
        if u.shape[-1] < 3:
            raise ParameterError(
                "u must have 3 uniforms per sample for rough_dielectric (2 for the normal, 1 "
                f"to choose reflection or refraction); got shape {tuple(u.shape)}"
            )
        return self._lobe_sample(wo, u, one_sided=False)

    def sample_one_sided(self, wo: Array, u: Array) -> Sample:
        """:meth:`sample` restricted to the upper hemisphere (``wi.z > 0``, where the lights of
        a one-sided render are): from outside reflect with probability 1 (not F), from inside
        refract with probability 1 where the microfacet does not reflect totally; the weight
        f·|cos θi|/p then carries F (or 1 − F) and no sample is wasted below the surface. Two
        uniforms suffice (a third is ignored)."""
        return self._lobe_sample(wo, u, one_sided=True)

    def _lobe_sample(self, wo: Array, u: Array, one_sided: bool) -> Sample:
        """A microfacet normal from the normals visible from ``wo`` (or D cos θh), then
        :meth:`_sample_at_normal`."""
        xp = namespace(wo, u)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo = xp.broadcast_to(wo, (*batch, 3))
        h = sample_normal(self.ndf, self.sample_visible, wo, u)
        return self._sample_at_normal(wo, h, u, one_sided)

    def _sample_at_normal(
        self, wo: Array, h: Array, u: Array, one_sided: bool, fresnel_terms: tuple | None = None
    ) -> Sample:
        """:meth:`_lobe_sample` on from its microfacet normal ``h`` (``wo`` broadcast to the batch
        already): reflect or refract by ``u[..., 2]``, the density and the weight.
        ``fresnel_terms``: :func:`~brdfkit.fresnel.fresnel` of ``wo·h``, where the caller has
        it (:func:`~brdfkit.brdf.kulla_conty_dielectric.dielectric_albedo` samples both
        branches at each normal)."""
        xp = namespace(wo, h, u)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo_h = dot(wo, h, keepdims=True)
        if fresnel_terms is None:
            fresnel_terms = fresnel(wo_h, param(self.eta, wo))
        f, cos_t, _, eta_ti = fresnel_terms
        choice = wo[..., 2:3] > 0 if one_sided else u[..., 2:3] < f
        reflect = choice | (f >= 1)  # total internal reflection whatever u
        reflected = 2 * wo_h * h - wo
        refracted = h * (wo_h * eta_ti + cos_t) - wo * eta_ti
        wi = xp.where(reflect, reflected, refracted)
        side = wi[..., 2:3] * wo[..., 2:3]
        ok = xp.where(reflect, side > 0, side < 0)
        pdf = self._lobe_pdf(wi, wo, one_sided)
        ok = ok & (pdf > 0)[..., None]
        value = self.eval(wi, wo)
        weight = safe_div(value * xp.abs(wi[..., 2:3]), pdf[..., None])
        weight = xp.where(ok, weight, xp.zeros_like(weight))
        pdf = xp.where(ok[..., 0], pdf, xp.zeros_like(pdf))
        return Sample(wi, weight, pdf, xp.zeros(batch, dtype=xp.bool))

    def _sampling_weight(self, wo: Array) -> Array:
        return interface_sampling_weight(wo)


__all__ = ["SMITH_MASKINGS", "RoughDielectric"]
