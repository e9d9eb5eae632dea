"""The Disney principled BRDF (Burley 2012, 2015), reflection only: :class:`Principled`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    asarrays,
    clamp,
    constant,
    dot,
    namespace,
    normalize,
    safe_div,
    safe_sqrt,
    to_numpy,
)
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    Sample,
    mixture_choices,
    normalized_weights,
    register,
    zero_unless,
)
from brdfkit.brdf.microfacet import GGX, masking_shadowing
from brdfkit.brdf.phong import reflect_about
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.params import Domain, param
from brdfkit.sampling import square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf

WEIGHT = Domain(0.0, 1.0, hint="a principled weight")
"""The principled BRDF's weights (metallic, roughness, sheen, …): [0, 1]."""

VARIANTS = ("mitsuba", "burley2012")
"""The sources :class:`Principled` can follow (module docstring)."""

_REC709 = (0.212671, 0.715160, 0.072169)  # Mitsuba 3's luminance of linear sRGB
_BURLEY_LUMINANCE = (0.3, 0.6, 0.1)  # disney.brdf's "luminance approx."
_CLEARCOAT_G_ALPHA = 0.25


def schlick_weight(cos_theta: Array) -> Array:
    r"""Schlick's weight :math:`(1 - \cos\theta)^5`, the cosine clamped to [0, 1]."""
    m = 1 - clamp(cos_theta, 0.0, 1.0)
    m2 = m * m
    return m2 * m2 * m


def gtr1(cos_theta_h: Array, alpha: Array) -> Array:
    r"""Burley's GTR1 (Berry) distribution, normalised so :math:`\int D\cos\theta_h = 1`:
    :math:`D = (\alpha^2 - 1)/(\pi\ln(\alpha^2)(1 + (\alpha^2 - 1)\cos^2\theta_h))`, 0 below."""
    xp = namespace(cos_theta_h, alpha)
    a2 = alpha * alpha
    value = (a2 - 1) / (math.pi * xp.log(a2) * (1 + (a2 - 1) * cos_theta_h * cos_theta_h))
    return xp.where(cos_theta_h > 0, value, xp.zeros_like(value))


def sample_gtr1(u: Array, alpha: Array) -> Array:
    r"""Normals with density :math:`D_{GTR1}\cos\theta_h`:
    :math:`\cos^2\theta_h = (1 - \alpha^{2(1-u_1)})/(1 - \alpha^2)`, φ = 2πu₀."""
    xp = namespace(u, alpha)
    a2 = alpha * alpha
    cos2 = (1 - a2 ** (1 - u[..., 1:2])) / (1 - a2)
    cos_theta = safe_sqrt(cos2)
    sin_theta = safe_sqrt(1 - cos2)
    phi = (2 * math.pi) * u[..., 0:1]
    x, y, z = xp.broadcast_arrays(sin_theta * xp.cos(phi), sin_theta * xp.sin(phi), cos_theta)
    return xp.concat([x, y, z], axis=-1)


def _lerp(a: Any, b: Any, t: Array) -> Array:
    return a + (b - a) * t


@register("principled")
@dataclass(frozen=True, eq=False)
class Principled(BRDF):
    r"""The Disney principled BRDF (Burley 2012, 2015), reflection only.

    A sum of lobes driven by artist-friendly weights in [0, 1] (``ωh`` the half vector,
    :math:`\theta_d` the angle between ωi and ωh, :math:`F_S(x) = (1 - x)^5` Schlick's
    weight, :math:`F_i = F_S(\cos\theta_i)`, :math:`F_o = F_S(\cos\theta_o)`,
    :math:`F_d = F_S(\cos\theta_d)`):

    .. math::
        f_r = (1 - m)\left[\frac{C}{\pi}\,\mathrm{lerp}(f_d, f_{ss}, s_{ss})
            + s_{sh} F_d\, C_{sh}\right]
            + \frac{F_s\,D_s\,G_s}{4\cos\theta_i\cos\theta_o} + f_{cc},

    - diffuse with retro-reflection, :math:`R_r = 2\rho\cos^2\theta_d` (ρ the ``roughness``):
      :math:`f_d = (1 - F_i/2)(1 - F_o/2) + R_r(F_i + F_o + F_iF_o(R_r - 1))` — Burley 2015's
      split, identical to 2012's :math:`(1 + (F_{D90} - 1)F_i)(1 + (F_{D90} - 1)F_o)`,
      :math:`F_{D90} = 1/2 + R_r`;
    - Hanrahan–Krueger-like "subsurface" flattening (Mitsuba's ``flatness``):
      :math:`f_{ss} = 1.25\,(F_{ss}(1/(\cos\theta_i + \cos\theta_o) - 1/2) + 1/2)`,
      :math:`F_{ss} = (1 + (F_{ss90} - 1)F_i)(1 + (F_{ss90} - 1)F_o)`, :math:`F_{ss90} = R_r/2`;
    - sheen, tinted :math:`C_{sh} = \mathrm{lerp}(1, C_{tint}, t_{sh})`,
      :math:`C_{tint} = C / \mathrm{lum}(C)`;
    - the main specular lobe: anisotropic GGX :math:`D_s` with
      :math:`\alpha_x = \max(10^{-3}, \rho^2/a)`, :math:`\alpha_y = \max(10^{-3}, \rho^2 a)`,
      :math:`a = \sqrt{1 - 0.9\,\text{anisotropic}}`, separable Smith :math:`G_s = G_1G_1`;
    - clearcoat: GTR1 :math:`D_{cc} = (\alpha^2 - 1)/(\pi\ln\alpha^2\,(1 + (\alpha^2 - 1)\cos^2
      \theta_h))` with :math:`\alpha = \mathrm{lerp}(0.1, 0.001, g_{cc})`, Schlick
      :math:`F_{cc} = 0.04 + 0.96F_d`, and GGX Smith :math:`G_{cc}` of α = 0.25.

    Two variants name the source they follow:

    ``variant="mitsuba"`` (default) is Mitsuba 3's ``principled`` with ``spec_trans = 0``, which
    follows Burley 2015: the dielectric specular Fresnel is the exact
    :func:`~brdfkit.fresnel.fresnel_dielectric` of :math:`\eta = 2/(1 - \sqrt{0.08\,s}) - 1` (the
    inverse of 2015's :math:`s = ((\eta-1)/(\eta+1))^2/0.08`),
    :math:`F_s = (1-m)(1-t_s)F_{diel} + m\,\mathrm{Schlick}(C) + (1-m)t_s\,
    \mathrm{Schlick}(C_{tint}R_0(\eta))`; lum is Rec. 709 luminance; and the clearcoat is
    :math:`f_{cc} = c/4\,F_{cc}D_{cc}G_{cc}` — *without* the microfacet
    :math:`1/(4\cos\theta_i\cos\theta_o)` of Burley's code (Mitsuba ``principled.cpp`` adds it
    to ``f cos θ`` that way). Mitsuba also drops the whole specular lobe where
    :math:`F_{diel} = 0` (``specular = 0``, η = 1, even for a metal); brdfkit does not.

    ``variant="burley2012"`` is Burley's reference code (``disney.brdf`` of the BRDF Explorer,
    2012 notes with the 2014 revision of :math:`G_s`): Schlick throughout,
    :math:`F_s = \mathrm{lerp}(C_{s0}, 1, F_d)`,
    :math:`C_{s0} = \mathrm{lerp}(0.08\,s\,\mathrm{lerp}(1, C_{tint}, t_s), C, m)`,
    lum = 0.3R + 0.6G + 0.1B, and :math:`f_{cc} = c/4\,F_{cc}D_{cc}G_{cc}/(4\cos\theta_i
    \cos\theta_o)`.

    Reciprocal: yes (every lobe is symmetric in ωi, ωo; the Fresnel terms use θd). Energy-
    conserving: no — the lobes are added without a balance (the diffuse is not reduced by the
    specular reflectance, and the retro-reflection makes :math:`f_d > 1` at grazing angles);
    ``tests/brdf/test_principled.py`` measures an albedo above 1.

    Sampled as Mitsuba does: a one-sample mixture of the cosine hemisphere (probability ∝ 1 − m),
    GGX visible normals from ωo (∝ 1) and GTR1 normals :math:`D_{cc}\cos\theta_h` (∝ c/4), with
    the mixture density as ``pdf``.

    Parameters
    ----------
    base_color : C, the colour ∈ [0, 1] (per channel; default 0.5).
    metallic, roughness, anisotropic, specular, specular_tint, sheen, sheen_tint, clearcoat,
    clearcoat_gloss, subsurface : weights in [0, 1] (defaults as Mitsuba: roughness 0.5, specular
        0.5, the others 0), scalars or per-pixel textures with a trailing axis of 1.
    variant : ``"mitsuba"`` (default) or ``"burley2012"``.

    References
    ----------
    .. [1] B. Burley, "Physically-based shading at Disney", SIGGRAPH 2012 course notes (revised
           2014); reference code ``disney.brdf``, Walt Disney Animation Studios BRDF Explorer.
    .. [2] B. Burley, "Extending the Disney BRDF to a BSDF with integrated subsurface scattering",
           SIGGRAPH 2015 course notes.
    .. [3] P. Hanrahan, W. Krueger, "Reflection from layered surfaces due to subsurface
           scattering", SIGGRAPH 1993.
    .. [4] W. Jakob et al., Mitsuba 3, ``src/bsdfs/principled.cpp``, ``principledhelpers.h``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Principled
    >>> f = Principled(base_color=[0.9, 0.6, 0.3], metallic=1.0, roughness=0.3)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.2437, 0.1625, 0.0813])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    base_color: Any = 0.5
    metallic: Any = 0.0
    roughness: Any = 0.5
    anisotropic: Any = 0.0
    specular: Any = 0.5
    specular_tint: Any = 0.0
    sheen: Any = 0.0
    sheen_tint: Any = 0.0
    clearcoat: Any = 0.0
    clearcoat_gloss: Any = 0.0
    subsurface: Any = 0.0
    variant: str = "mitsuba"
    reciprocal: ClassVar[bool] = True
    energy_conserving: ClassVar[bool] = False
    domains: ClassVar[dict[str, Domain]] = {
        "base_color": ALBEDO,
        "metallic": WEIGHT,
        "roughness": WEIGHT,
        "anisotropic": WEIGHT,
        "specular": WEIGHT,
        "specular_tint": WEIGHT,
        "sheen": WEIGHT,
        "sheen_tint": WEIGHT,
        "clearcoat": WEIGHT,
        "clearcoat_gloss": WEIGHT,
        "subsurface": WEIGHT,
    }
    _SCALARS: ClassVar[tuple[str, ...]] = (
        "metallic",
        "roughness",
        "anisotropic",
        "specular",
        "specular_tint",
        "sheen",
        "sheen_tint",
        "clearcoat",
        "clearcoat_gloss",
        "subsurface",
    )

    choices: ClassVar[dict[str, tuple[str, ...]]] = {"variant": VARIANTS}

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in self._SCALARS:
            if np.shape(to_numpy(getattr(self, name)))[-1:] not in ((), (1,)):
                raise ParameterError(
                    f"{name} must be one weight per point (a trailing axis of 1); got shape "
                    f"{np.shape(to_numpy(getattr(self, name)))}"
                )
        roughness, anisotropic = asarrays(self.roughness, self.anisotropic)
        xp = namespace(roughness, anisotropic)
        aspect = xp.sqrt(1 - 0.9 * anisotropic)
        r2 = roughness * roughness
        floor = constant(1e-3, r2)
        object.__setattr__(
            self, "ndf", GGX(xp.maximum(floor, r2 / aspect), xp.maximum(floor, r2 * aspect))
        )

    def _channel_values(self) -> dict[str, Any]:
        """The base colour (the weights are one per point)."""
        return {"base_color": self.base_color}

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return bool(np.all(to_numpy(self.anisotropic) == 0))

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(base_color=[0.9, 0.6, 0.3], metallic=1.0, roughness=0.3),
            cls(base_color=[0.2, 0.4, 0.8], roughness=0.6, clearcoat=1.0, clearcoat_gloss=0.6),
            cls(
                base_color=[0.7, 0.3, 0.3],
                roughness=0.9,
                sheen=1.0,
                sheen_tint=0.5,
                subsurface=0.7,
            ),
            cls(
                base_color=[0.5, 0.8, 0.3],
                metallic=0.4,
                roughness=0.4,
                anisotropic=0.8,
                specular=0.8,
                specular_tint=0.6,
            ),
            cls(
                base_color=[0.6, 0.5, 0.4],
                roughness=0.5,
                anisotropic=0.5,
                specular_tint=0.3,
                sheen=0.5,
                clearcoat=0.5,
                clearcoat_gloss=0.3,
                variant="burley2012",
            ),
        ]

    # -- the lobes ----------------------------------------------------------------------------
    def _tint(self, color: Array) -> Array:
        """:math:`C/\\mathrm{lum}(C)` (1 where the luminance is 0); grey for C ≠ 3 channels."""
        xp = namespace(color)
        if color.shape[-1] == 3:
            w = _REC709 if self.variant == "mitsuba" else _BURLEY_LUMINANCE
            lum = w[0] * color[..., 0:1] + w[1] * color[..., 1:2] + w[2] * color[..., 2:3]
        else:
            lum = xp.mean(color, axis=-1, keepdims=True)
        return xp.where(lum > 0, safe_div(color, lum), xp.ones_like(color))

    def _eta(self, like: Array) -> Array:
        specular = param(self.specular, like)
        return 2 / (1 - namespace(specular).sqrt(0.08 * specular)) - 1

    def _specular_fresnel(self, cos_d: Array, color: Array, tint: Array, like: Array) -> Array:
        metallic = param(self.metallic, like)
        specular_tint = param(self.specular_tint, like)
        weight = schlick_weight(cos_d)
        if self.variant == "burley2012":
            specular = param(self.specular, like)
            c_spec0 = _lerp(0.08 * specular * _lerp(1.0, tint, specular_tint), color, metallic)
            return _lerp(c_spec0, 1.0, weight)
        eta = self._eta(like)
        f_dielectric = fresnel_dielectric(cos_d, eta)
        r0 = ((eta - 1) / (eta + 1)) ** 2
        schlick_metal = _lerp(color, 1.0, weight)
        schlick_tint = _lerp(tint * r0, 1.0, weight)
        return (
            (1 - metallic) * (1 - specular_tint) * f_dielectric
            + metallic * schlick_metal
            + (1 - metallic) * specular_tint * schlick_tint
        )

    def _clearcoat_alpha(self, like: Array) -> Array:
        return _lerp(0.1, 0.001, param(self.clearcoat_gloss, like))

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        color = param(self.base_color, wi)
        metallic = param(self.metallic, wi)
        roughness = param(self.roughness, wi)
        cos_i, cos_o = wi[..., 2:3], wo[..., 2:3]
        h = normalize(wi + wo)
        cos_d = clamp(dot(wi, h, keepdims=True), 0.0, 1.0)
        f_i, f_o, f_d = schlick_weight(cos_i), schlick_weight(cos_o), schlick_weight(cos_d)
        tint = self._tint(color)
        # Diffuse, retro-reflection and the subsurface approximation.
        rr = 2 * roughness * cos_d * cos_d
        f_diffuse = (1 - 0.5 * f_i) * (1 - 0.5 * f_o) + rr * (f_i + f_o + f_i * f_o * (rr - 1))
        f_ss90 = 0.5 * rr
        f_ss = _lerp(1.0, f_ss90, f_i) * _lerp(1.0, f_ss90, f_o)
        ss = 1.25 * (f_ss * (safe_div(xp.ones_like(cos_i), cos_i + cos_o) - 0.5) + 0.5)
        diffuse = color / math.pi * _lerp(f_diffuse, ss, param(self.subsurface, wi))
        sheen = param(self.sheen, wi) * f_d * _lerp(1.0, tint, param(self.sheen_tint, wi))
        value = (1 - metallic) * (diffuse + sheen)
        # The main specular lobe.
        inv_4cos = safe_div(xp.ones_like(cos_i), 4 * cos_i * cos_o)
        d = self.ndf.D(h)
        g = masking_shadowing(self.ndf, wi, wo, h, "smith_separable")
        value = value + self._specular_fresnel(cos_d, color, tint, wi) * d * g * inv_4cos
        # The clearcoat.
        clearcoat = param(self.clearcoat, wi)
        if bool(np.any(to_numpy(self.clearcoat) != 0)) or hasattr(self.clearcoat, "shape"):
            d_cc = gtr1(h[..., 2:3], self._clearcoat_alpha(wi))
            coat_ndf = GGX(_CLEARCOAT_G_ALPHA)
            g_cc = coat_ndf.G1(wi, h) * coat_ndf.G1(wo, h)
            f_cc = 0.25 * clearcoat * (0.04 + 0.96 * f_d) * d_cc * g_cc
            if self.variant == "burley2012":
                f_cc = f_cc * inv_4cos
            value = value + f_cc
        return value

    # -- sampling -----------------------------------------------------------------------------
    def _sampling_weight(self, wo: Array) -> Array:
        """A cheap grey albedo estimate, ``(...,)``: the diffuse colour, the specular Fresnel
        and the clearcoat's at θo (no masking)."""
        xp = namespace(wo)
        color = param(self.base_color, wo)
        cos_o = clamp(wo[..., 2:3], 0.0, 1.0)
        tint = self._tint(color)
        estimate = (1 - param(self.metallic, wo)) * (color + param(self.sheen, wo) * 0.1)
        estimate = estimate + self._specular_fresnel(cos_o, color, tint, wo)
        coat = 0.04 + 0.96 * schlick_weight(cos_o)
        estimate = estimate + 0.25 * param(self.clearcoat, wo) * coat
        return xp.mean(estimate + xp.zeros_like(cos_o), axis=-1)

    def _probabilities(self, wo: Array) -> list[Array]:
        """Lobe probabilities (diffuse, specular, clearcoat), ``(...,)`` each, as Mitsuba."""
        xp = namespace(wo)
        zero = xp.zeros_like(wo[..., 0])
        diffuse = (1 - param(self.metallic, wo))[..., 0] + zero
        clearcoat = 0.25 * param(self.clearcoat, wo)[..., 0] + zero
        return normalized_weights([diffuse, xp.ones_like(diffuse), clearcoat])

    def _pdf(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        p_diffuse, p_specular, p_clearcoat = self._probabilities(wo)
        h = normalize(wi + wo)
        wo_h = dot(wo, h)
        jacobian = safe_div(xp.ones_like(wo_h), 4 * wo_h)
        specular = self.ndf.pdf_visible(wo, h) * jacobian
        alpha_cc = self._clearcoat_alpha(wo)[..., 0]
        clearcoat = gtr1(h[..., 2], alpha_cc) * h[..., 2] * jacobian
        diffuse = square_to_cosine_hemisphere_pdf(wi)
        value = p_diffuse * diffuse + p_specular * specular + p_clearcoat * clearcoat
        return zero_unless(wo_h > 0, value)

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        u = asarray(u, xp, like=wo)  # NumPy uniforms with torch directions compute in torch
        choices = mixture_choices(self._probabilities(wo), u)
        (pick_d, u_d), (pick_s, u_s), (_, u_c) = choices
        wi_d = square_to_cosine_hemisphere(u_d[..., :2])
        wi_s = reflect_about(wo, self.ndf.sample_visible(wo, u_s[..., :2]))
        wi_c = reflect_about(wo, sample_gtr1(u_c[..., :2], self._clearcoat_alpha(wo)))
        wi_d, wi_s, wi_c = xp.broadcast_arrays(wi_d, wi_s, wi_c)
        wi = xp.where(pick_d[..., None], wi_d, xp.where(pick_s[..., None], wi_s, wi_c))
        wi, wo_b = xp.broadcast_arrays(wi, wo)
        pdf = self.pdf(wi, wo_b)
        # a denormal density is a far tail, where f cos θi / p would overflow: failed
        ok = (pdf > xp.finfo(pdf.dtype).smallest_normal) & (wi[..., 2] > 0)
        safe_pdf = xp.where(ok, pdf, xp.ones_like(pdf))
        weight = self.eval(wi, wo_b) * (wi[..., 2] / safe_pdf)[..., None]
        return Sample(wi, weight, xp.where(ok, pdf, xp.zeros_like(pdf)), False)


__all__ = ["VARIANTS", "Principled", "gtr1", "sample_gtr1", "schlick_weight"]
