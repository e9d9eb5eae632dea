r"""Phong-family lobes: the original Phong model, its physically plausible (modified) version,
normalised Blinn–Phong, and the cosine-power lobe and lobe-mixture sampling they share.

The cosine-power lobe :math:`\frac{n+1}{2\pi}\cos^n\alpha` about an axis is sampled exactly by
:math:`\cos\alpha = u_1^{1/(n+1)}`, :math:`\varphi = 2\pi u_2`. Every model here (and the
Lafortune, Ward and Oren–Nayar models, which import :class:`MixtureSampled`) samples a mixture
of such lobes and the cosine-weighted hemisphere, chosen with probabilities that depend on
``wo`` only; ``pdf`` is the exact mixture density and ``weight = f cos θi / pdf``.

References
----------
.. [1] B. T. Phong, "Illumination for computer generated pictures", Commun. ACM 18(6), 1975.
.. [2] J. F. Blinn, "Models of light reflection for computer synthesized pictures",
       SIGGRAPH 1977.
.. [3] E. P. Lafortune, Y. D. Willems, "Using the modified Phong reflectance model for
       physically based rendering", Tech. Rep. CW197, KU Leuven, 1994.
.. [4] R. R. Lewis, "Making shaders more physically plausible", Computer Graphics Forum 13(2),
       1994.
.. [5] T. Akenine-Möller, E. Haines, N. Hoffman, *Real-Time Rendering*, 3rd ed., §7.6, 2008.
.. [6] F. Giesen, "Derivation of Phong and Blinn-Phong BRDF normalization factors", 2009.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    check_param,
    dot,
    namespace,
    normalize,
    safe_sqrt,
    to_numpy,
)
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    EXPONENT,
    Sample,
    mixture_choices,
    normalized_weights,
    positive_or_one,
    register,
)
from brdfkit.geometry import frame_from_normal, reflect, to_world
from brdfkit.params import (
    UNPHYSICAL_MAX,
    Domain,
    channel_count,
    check_choice,
    check_flag,
    param,
)
from brdfkit.sampling import square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf

Component = tuple[Array, Callable[[Array], Array], Callable[[Array], Array]]
"""One mixture component: ``(probability (...,), pdf(wi) -> (...,), sample(u2) -> wi)``."""


# --------------------------------------------------------------------------- cosine-power lobe
def cosine_power(cos_alpha: Array, n: Array) -> Array:
    r"""``max(cos α, 0)ⁿ``: 0 where cos α ≤ 0, with finite gradients in ``cos_alpha`` and ``n``.

    ``cos_alpha`` ``(..., 1)`` and ``n`` ``(..., C)`` broadcast to ``(..., C)``.
    """
    xp = namespace(cos_alpha, n)
    positive = cos_alpha > 0
    base = xp.where(positive, cos_alpha, xp.ones_like(cos_alpha))
    value = base**n
    return xp.where(positive, value, xp.zeros_like(value))


def cosine_lobe_pdf(cos_alpha: Array, n: Array) -> Array:
    r"""Solid-angle density :math:`\frac{n+1}{2\pi}\max(\cos\alpha, 0)^n` of the cosine-power lobe.

    References
    ----------
    .. [1] E. P. Lafortune, Y. D. Willems, Tech. Rep. CW197, KU Leuven, 1994, §3.
    """
    return (n + 1) / (2 * math.pi) * cosine_power(cos_alpha, n)


def sample_cosine_lobe(axis: Array, n: Array, u: Array) -> Array:
    r"""Directions distributed as :math:`\frac{n+1}{2\pi}\cos^n\alpha` about the unit ``axis``.

    :math:`\cos\alpha = u_1^{1/(n+1)}` inverts the marginal CDF :math:`\cos^{n+1}\alpha` exactly
    and :math:`\varphi = 2\pi u_2`; ``n`` has shape ``(...,)``.

    References
    ----------
    .. [1] E. P. Lafortune, Y. D. Willems, Tech. Rep. CW197, KU Leuven, 1994, §3.
    """
    xp = namespace(axis, n, u)
    cos_alpha = u[..., 0] ** (1 / (n + 1))
    sin_alpha = safe_sqrt(1 - cos_alpha * cos_alpha)
    phi = 2 * math.pi * u[..., 1]
    local = xp.stack([sin_alpha * xp.cos(phi), sin_alpha * xp.sin(phi), cos_alpha], axis=-1)
    return to_world(local, frame_from_normal(axis))


def reflect_about(wo: Array, h: Array) -> Array:
    """Mirror ``wo`` about the unit vector ``h``: 2(wo·h)h − wo."""
    return 2 * dot(wo, h, keepdims=True) * h - wo


def channel_mean(value: Array) -> Array:
    """Mean over the channel (last) axis: ``(..., C)`` → ``(...,)``.

    A channel-varying shape parameter (exponent, roughness) is reduced this way for sampling.
    """
    xp = namespace(value)
    return xp.mean(value, axis=-1)


# --------------------------------------------------------------------------- mixtures
def cosine_component(probability: Array) -> Component:
    """The cosine-weighted hemisphere as a mixture component."""
    return probability, square_to_cosine_hemisphere_pdf, square_to_cosine_hemisphere


class MixtureSampled(BRDF):
    """A BRDF sampled by a ``wo``-dependent mixture of lobes (one-sample MIS, balance heuristic).

    Subclasses implement :meth:`components`; the density is the exact mixture density and
    a sample picks component k with probability p_k by ``u[..., 0]`` (re-stretched for the
    component), then has ``weight = f cos θi / pdf``; samples below the surface get weight 0.

    References
    ----------
    .. [1] E. Veach, *Robust Monte Carlo methods for light transport simulation*, PhD thesis,
           Stanford, 1997, §9.2.4.
    """

    def components(self, wo: Array) -> list[Component]:
        """The mixture ``[(probability, pdf, sampler), ...]`` at ``wo``; probabilities sum to 1."""
        raise NotImplementedError

    def _pdf(self, wi: Array, wo: Array) -> Array:
        total = None
        for probability, pdf, _ in self.components(wo):
            term = probability * pdf(wi)
            total = term if total is None else total + term
        return total

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        u = asarray(u, xp, dtype=wo.dtype)
        components = self.components(wo)
        choices = mixture_choices([probability for probability, _, _ in components], u[..., :2])
        wi = None
        for (_, _, sampler), (pick, u_k) in zip(components, choices, strict=True):
            w_k = sampler(u_k)
            wi = w_k if wi is None else xp.where(pick[..., None], w_k, wi)
        pdf = self.pdf(wi, wo)
        safe_pdf = xp.where(pdf > 0, pdf, xp.ones_like(pdf))
        weight = self.eval(wi, wo) * (wi[..., 2] / safe_pdf)[..., None]
        return Sample(wi, weight, pdf, False)


PHONG_KD = Domain(0.0, 1 / math.pi, hint="π·kd is the diffuse albedo", unphysical_hi=UNPHYSICAL_MAX)
"""The original Phong model's diffuse BRDF value k_d: [0, 1/π] sr⁻¹ (up to 10⁶ unphysical)."""

PHONG_KS = Domain(0.0, UNPHYSICAL_MAX, hint="specular coefficient in sr⁻¹")
"""The original Phong model's specular coefficient k_s: [0, 10⁶] sr⁻¹."""


ALBEDOS: dict[str, Domain] = {"kd": ALBEDO, "ks": ALBEDO, "n": EXPONENT}
"""The domains of the albedo-parametrised lobes (modified Phong, Blinn–Phong): ρd, ρs ∈ [0, 1]
(each up to 10⁶ with ``allow_unphysical``) and the exponent n."""


def check_albedo_sum(kd: Any, ks: Any, allow_unphysical: Any) -> None:
    """ρd + ρs ≤ 1 (energy conservation) unless ``allow_unphysical``, for ρd, ρs already
    checked against their domains (:func:`~brdfkit.params.check_domains`); they must share
    their channels."""
    hint = "pass allow_unphysical=True to allow it"
    unphysical = check_flag("allow_unphysical", allow_unphysical)
    channel_count(kd, ks, names=("kd", "ks"))
    if not unphysical:
        total = to_numpy(kd).astype(np.float64) + to_numpy(ks).astype(np.float64)
        check_param("kd + ks", total, 0.0, 1.0, hint="ρd + ρs ≤ 1 conserves energy; " + hint)


def _mirror_cosine(wi: Array, wo: Array) -> Array:
    """cos α = wi · reflect(wo) = 2 cosθi cosθo − wi·wo, as ``(..., 1)``."""
    return dot(wi, reflect(wo), keepdims=True)


# --------------------------------------------------------------------------- original Phong
@register("phong")
@dataclass(frozen=True, eq=False)
class Phong(MixtureSampled):
    r"""The original Phong model (1975) written as a BRDF, as the lectures write it.

    .. math::

        f_r = k_d + k_s \frac{\cos^n\theta_r}{\cos\theta_i},\qquad
        \cos\theta_r = \omega_o\cdot\mathbf r,\quad \mathbf r = 2(\mathbf n\cdot\omega_i)
        \mathbf n - \omega_i

    (0 where cos θr ≤ 0). The shading formula L_o = L_i (k_d cos θi + k_s cosⁿθr) divided by
    L_i cos θi gives the 1/cos θi. **Not reciprocal** (f(ωi, ωo) − f(ωo, ωi) =
    k_s cosⁿθr (1/cos θi − 1/cos θo)) and **not energy-conserving**: the specular albedo at
    normal incidence is k_s·2π/(n+1) for any k_s ≥ 0, and the 1/cos θi makes f unbounded at
    grazing light. Use :class:`ModifiedPhong` for a physically plausible version.

    Sampled by a mixture of the cosine-weighted hemisphere and the cosⁿ lobe about the mirror
    direction of ``wo`` (f cos θi = k_d cos θi + k_s cosⁿα exactly); a channel-varying ``n`` is
    sampled with its channel mean.

    Parameters
    ----------
    kd : diffuse BRDF value k_d ∈ [0, 1/π] sr⁻¹ (diffuse albedo π k_d ≤ 1); larger values, up
        to 10⁶, need ``allow_unphysical=True``.
    ks : specular coefficient k_s ∈ [0, 10⁶] sr⁻¹.
    n : Phong exponent n ∈ [0, 10⁶] (shininess).
    All broadcast against ``batch + (C,)``.

    References
    ----------
    .. [1] B. T. Phong, "Illumination for computer generated pictures", Commun. ACM 18(6),
           311–317, 1975.
    .. [2] J. Křivánek, Computer Graphics III lecture "Light reflection, BRDF" (PhongOrig).

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Phong
    >>> f = Phong(kd=0.1, ks=0.1, n=10.0)
    >>> wi, wo = np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.0, 1.0])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1134])
    >>> np.round(f.eval(wo, wi), 4)
    array([0.1107])
    """

    reciprocal = False
    energy_conserving = False

    kd: Any = 0.1
    ks: Any = 0.1
    n: Any = 10.0
    allow_unphysical: bool = False
    domains: ClassVar[dict[str, Domain]] = {"kd": PHONG_KD, "ks": PHONG_KS, "n": EXPONENT}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(0.3 / math.pi, 0.05, 1.0),
            cls(0.1, 0.1, 10.0),
            cls(0.0, 0.02, 100.0),
            cls([0.25, 0.15, 0.05], 0.05, 40.0),
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        kd, ks, n = param(self.kd, wi), param(self.ks, wi), param(self.n, wi)
        cos_theta_r = _mirror_cosine(wi, wo)
        return kd + ks * cosine_power(cos_theta_r, n) / positive_or_one(wi[..., 2:3])

    def _specular_weight(self, wo: Array) -> Array:
        """Mean specular albedo at normal incidence, k_s·2π/(n+1), ``(...,)``-broadcastable."""
        ks, n = param(self.ks, wo), param(self.n, wo)
        return channel_mean(ks * 2 * math.pi / (n + 1))

    def components(self, wo: Array) -> list[Component]:
        diffuse = channel_mean(math.pi * param(self.kd, wo))
        specular = self._specular_weight(wo)
        return diffuse_and_lobe(wo, diffuse, specular, (self.n,), *_mirror_lobe(wo))

    def _sampling_weight(self, wo: Array) -> Array:
        return channel_mean(math.pi * param(self.kd, wo)) + self._specular_weight(wo)


# --------------------------------------------------------------------------- modified Phong
@register("modified_phong")
@dataclass(frozen=True, eq=False)
class ModifiedPhong(MixtureSampled):
    r"""The physically plausible ("modified") Phong BRDF of Lafortune & Willems and Lewis (1994).

    .. math::

        f_r = \frac{\rho_d}{\pi} + \rho_s\,\frac{n+2}{2\pi}\,\cos^n\alpha,\qquad
        \cos\alpha = \omega_i\cdot\mathrm{reflect}(\omega_o)

    (0 where cos α ≤ 0). **Reciprocal** (cos α is symmetric in ωi, ωo). **Energy-conserving**
    when ρd + ρs ≤ 1: the specular albedo is exactly ρs at normal incidence and smaller
    elsewhere (the lobe is clipped by the horizon and weighted by cos θi ≤ cos α).

    Sampled by a mixture of the cosine-weighted hemisphere (probability ∝ ρd) and the exact
    cosⁿ lobe about reflect(ωo) (probability ∝ ρs); lobe samples below the surface get weight 0.
    A channel-varying ``n`` is sampled with its channel mean.

    Parameters
    ----------
    kd : diffuse albedo ρd ∈ [0, 1].
    ks : specular albedo ρs ∈ [0, 1]; ρd + ρs ≤ 1 unless ``allow_unphysical=True`` (then ρd,
        ρs ∈ [0, 10⁶]).
    n : exponent n ∈ [0, 10⁶].

    References
    ----------
    .. [1] E. P. Lafortune, Y. D. Willems, "Using the modified Phong reflectance model for
           physically based rendering", Tech. Rep. CW197, KU Leuven, 1994.
    .. [2] R. R. Lewis, "Making shaders more physically plausible", Computer Graphics Forum
           13(2), 109–120, 1994.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import ModifiedPhong
    >>> f = ModifiedPhong(kd=0.5, ks=0.3, n=20.0)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.3948])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    kd: Any = 0.5
    ks: Any = 0.3
    n: Any = 20.0
    allow_unphysical: bool = False
    domains: ClassVar[dict[str, Domain]] = ALBEDOS

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        return not self.allow_unphysical

    def __post_init__(self) -> None:
        super().__post_init__()
        check_albedo_sum(self.kd, self.ks, self.allow_unphysical)

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(0.9, 0.1, 0.0),
            cls(0.5, 0.5, 5.0),
            cls(0.2, 0.7, 50.0),
            cls(0.0, 1.0, 500.0),
            cls([0.6, 0.3, 0.1], [0.2, 0.3, 0.4], [10.0, 20.0, 40.0]),
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        kd, ks, n = param(self.kd, wi), param(self.ks, wi), param(self.n, wi)
        cos_alpha = _mirror_cosine(wi, wo)
        return kd / math.pi + ks * (n + 2) / (2 * math.pi) * cosine_power(cos_alpha, n)

    def components(self, wo: Array) -> list[Component]:
        kd, ks = channel_mean(param(self.kd, wo)), channel_mean(param(self.ks, wo))
        return diffuse_and_lobe(wo, kd, ks, (self.n,), *_mirror_lobe(wo))

    def _sampling_weight(self, wo: Array) -> Array:
        return albedo_bound(self.kd, self.ks, wo)


def _mirror_lobe(wo: Array) -> tuple[Callable[..., Array], Callable[..., Array]]:
    """``(pdf(wi, n), sample(u, n))`` of the cosⁿ lobe about reflect(wo)."""
    axis = reflect(wo)
    return (
        lambda wi, n: cosine_lobe_pdf(_mirror_cosine(wi, wo)[..., 0], n),
        lambda u, n: sample_cosine_lobe(axis, n, u),
    )


def diffuse_and_lobe(
    wo: Array,
    diffuse_weight: Array,
    lobe_weight: Array,
    lobe_params: tuple[Any, ...],
    lobe_pdf: Callable[..., Array],
    lobe_sample: Callable[..., Array],
) -> list[Component]:
    """Cosine hemisphere and one lobe, chosen ∝ their weights.

    The lobe is ``lobe_pdf(wi, *means)`` and ``lobe_sample(u, *means)`` with ``means`` the
    channel means of ``lobe_params`` (its exponent or roughness), broadcast to ``wo``'s batch.
    """
    xp = namespace(wo)
    batch = wo.shape[:-1]
    p_d, p_s = normalized_weights(
        [xp.broadcast_to(diffuse_weight, batch), xp.broadcast_to(lobe_weight, batch)]
    )
    means = [xp.broadcast_to(channel_mean(param(value, wo)), batch) for value in lobe_params]
    return [
        cosine_component(p_d),
        (p_s, lambda wi: lobe_pdf(wi, *means), lambda u: lobe_sample(u, *means)),
    ]


def albedo_bound(kd: Any, ks: Any, wo: Array) -> Array:
    """ρd + ρs (channel mean), the albedo at normal incidence; broadcastable to ``(...,)``."""
    return channel_mean(param(kd, wo) + param(ks, wo))


# --------------------------------------------------------------------------- Blinn–Phong
_BLINN_NORMALIZATIONS = ("exact", "rtr")


def blinn_phong_normalization(n: Array, normalization: str = "exact") -> Array:
    r"""The constant c(n) of the normalised Blinn–Phong lobe :math:`c(n)\cos^n\theta_h`.

    ``"exact"``: :math:`c = \frac{(n+2)(n+4)}{8\pi\,(2^{-n/2} + n)}`, the value that makes
    :math:`\int c\cos^n\theta_h\cos\theta_i\,d\omega_i = 1` at normal incidence (Giesen 2009;
    the integral is :math:`\int_0^{\pi/4} \cos^n\theta_h\cos 2\theta_h\,4\cos\theta_h\,2\pi
    \sin\theta_h\,d\theta_h`). ``"rtr"``: :math:`c = \frac{n+8}{8\pi}`, the approximation of
    Akenine-Möller, Haines & Hoffman (*Real-Time Rendering*, 3rd ed., eq. 7.49).

    References
    ----------
    .. [1] F. Giesen, "Derivation of Phong and Blinn-Phong BRDF normalization factors", 2009.
    .. [2] T. Akenine-Möller, E. Haines, N. Hoffman, *Real-Time Rendering*, 3rd ed., 2008.
    """
    check_choice("normalization", normalization, _BLINN_NORMALIZATIONS)
    if normalization == "exact":
        return (n + 2) * (n + 4) / (8 * math.pi * (2 ** (-n / 2) + n))
    return (n + 8) / (8 * math.pi)


def _half_cosine(wi: Array, wo: Array) -> Array:
    """cos θh = n·normalize(wi + wo), as ``(..., 1)``."""
    return normalize(wi + wo)[..., 2:3]


def reflected_pdf(wi: Array, wo: Array, half_pdf: Callable[[Array], Array]) -> Array:
    r"""Density of wi = reflect(wo, h) when h has density ``half_pdf(h)``: p_h(h) / (4 wo·h).

    ``h = normalize(wi + wo)``; 0 where wo·h ≤ 0.

    References
    ----------
    .. [1] K. E. Torrance, E. M. Sparrow, "Theory for off-specular reflection from roughened
           surfaces", JOSA 57(9), 1967 (the 1/(4 wo·h) Jacobian).
    """
    xp = namespace(wi, wo)
    h = normalize(wi + wo)
    wo_dot_h = dot(wo, h)
    ok = wo_dot_h > 0
    safe = xp.where(ok, wo_dot_h, xp.ones_like(wo_dot_h))
    value = half_pdf(h) / (4 * safe)
    return xp.where(ok, value, xp.zeros_like(value))


@register("blinn_phong")
@dataclass(frozen=True, eq=False)
class BlinnPhong(MixtureSampled):
    r"""Normalised Blinn–Phong: a diffuse term plus a normalised cosⁿ of the half-vector angle.

    .. math::

        f_r = \frac{\rho_d}{\pi} + \rho_s\,c(n)\,\cos^n\theta_h,\qquad
        \cos\theta_h = \mathbf n\cdot\frac{\omega_i+\omega_o}{\lVert\omega_i+\omega_o\rVert}

    with c(n) from :func:`blinn_phong_normalization`: ``normalization="exact"`` (default,
    c = (n+2)(n+4)/(8π(2^{-n/2}+n))) makes the specular albedo exactly ρs at normal incidence,
    and it is smaller at every other ``wo`` (measured in the tests), so the model is
    **energy-conserving** when ρd + ρs ≤ 1. ``normalization="rtr"`` (c = (n+8)/(8π), Real-Time
    Rendering) overshoots: for n ≥ 1 its normal-incidence albedo exceeds ρs by up to ≈ 7.5 %
    (n ≈ 10), so that variant is **not energy-conserving**. Both are **reciprocal** (θh is
    symmetric).

    Sampled by a mixture of the cosine-weighted hemisphere (∝ ρd) and half vectors from
    (n+1)/(2π) cosⁿθh reflected about h, with density p_h/(4 ωo·h) (∝ ρs); a channel-varying
    ``n`` is sampled with its channel mean.

    Parameters
    ----------
    kd : diffuse albedo ρd ∈ [0, 1].
    ks : specular albedo ρs ∈ [0, 1]; ρd + ρs ≤ 1 unless ``allow_unphysical=True`` (then ρd,
        ρs ∈ [0, 10⁶]).
    n : exponent n ∈ [0, 10⁶].
    normalization : ``"exact"`` or ``"rtr"``.

    References
    ----------
    .. [1] J. F. Blinn, "Models of light reflection for computer synthesized pictures",
           SIGGRAPH 1977.
    .. [2] F. Giesen, "Derivation of Phong and Blinn-Phong BRDF normalization factors", 2009.
    .. [3] T. Akenine-Möller, E. Haines, N. Hoffman, *Real-Time Rendering*, 3rd ed., 2008.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import BlinnPhong
    >>> f = BlinnPhong(kd=0.5, ks=0.3, n=40.0)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.3437])
    >>> float(np.round(f.pdf(wi, wo), 4))
    0.4082
    """

    kd: Any = 0.5
    ks: Any = 0.3
    n: Any = 40.0
    normalization: str = "exact"
    allow_unphysical: bool = False
    domains: ClassVar[dict[str, Domain]] = ALBEDOS

    choices: ClassVar[dict[str, tuple[str, ...]]] = {"normalization": _BLINN_NORMALIZATIONS}

    def __post_init__(self) -> None:
        super().__post_init__()
        check_albedo_sum(self.kd, self.ks, self.allow_unphysical)

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        return self.normalization == "exact" and not self.allow_unphysical

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(0.9, 0.1, 0.0),
            cls(0.5, 0.5, 8.0),
            cls(0.2, 0.7, 100.0),
            cls(0.0, 1.0, 1000.0),
            cls(0.3, 0.6, 30.0, normalization="rtr"),
            cls([0.6, 0.3, 0.1], [0.2, 0.3, 0.4], [10.0, 20.0, 40.0]),
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        kd, ks, n = param(self.kd, wi), param(self.ks, wi), param(self.n, wi)
        c = blinn_phong_normalization(n, self.normalization)
        return kd / math.pi + ks * c * cosine_power(_half_cosine(wi, wo), n)

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        normal = xp.broadcast_to(asarray([0.0, 0.0, 1.0], xp, like=wo), wo.shape)
        kd, ks = channel_mean(param(self.kd, wo)), channel_mean(param(self.ks, wo))
        return diffuse_and_lobe(
            wo,
            kd,
            ks,
            (self.n,),
            lambda wi, n: reflected_pdf(wi, wo, lambda h: cosine_lobe_pdf(h[..., 2], n)),
            lambda u, n: reflect_about(wo, sample_cosine_lobe(normal, n, u)),
        )

    def _sampling_weight(self, wo: Array) -> Array:
        return albedo_bound(self.kd, self.ks, wo)


__all__ = ["BlinnPhong", "ModifiedPhong", "Phong"]
