r"""Plastics: a diffuse base under a dielectric coating, smooth or rough (Mitsuba 3's
``plastic`` and ``roughplastic``).

Light either reflects off the coating (a mirror, or GGX/Beckmann microfacets, with the exact
dielectric Fresnel factor of η = n_coating / n_outside), or enters it, scatters off a
Lambertian base of albedo ρ, bounces between base and coating, and leaves. With :math:`T(\mu)`
the coating's transmittance at :math:`\mu = \cos\theta` and :math:`\bar F_{int}` its diffuse
reflectance seen from inside, the diffuse part is

.. math::
    f_{diffuse}(\omega_i, \omega_o) = \frac{\rho'}{\pi\eta^2}\,T(\cos\theta_i)\,
        T(\cos\theta_o),\qquad
    \rho' = \frac{\rho}{1 - \bar F_{int}}\ \text{(default)}\quad\text{or}\quad
    \frac{\rho}{1 - \rho\bar F_{int}}\ \text{(``nonlinear=True``)}.

The factor :math:`1/\eta^2` is the radiance compression of entering the denser coating. The
nonlinear form is the geometric series of the inter-reflections (its colour saturates as in
a real varnished surface); the default keeps the total diffuse albedo at ρ(1 − F(θo)) exactly
(Mitsuba's default). :math:`\bar F_{int} = 1 - (1 - \bar F_{ext})/\eta^2` with
:math:`\bar F_{ext} = \int_0^1 F(\mu)\,2\mu\,d\mu` (the reciprocity of the transmittance
through an interface makes this exact).

References
----------
.. [1] C. Kelemen, L. Szirmay-Kalos, "A microfacet based coupled specular-matte BRDF model
       with importance sampling", Eurographics short papers, 2001.
.. [2] B. Walter et al., "Microfacet models for refraction through rough surfaces", EGSR 2007.
.. [3] E. d'Eon, G. Irving, "A quantized-diffusion model for rendering translucent
       materials", SIGGRAPH 2011 (the fit of :math:`\bar F_{ext}`); R. Egan, D. Hilgeman, 1973
       (that of :math:`\bar F_{int}` for η < 1).
.. [4] W. Jakob et al., Mitsuba 3, ``src/bsdfs/plastic.cpp``, ``roughplastic.cpp``,
       ``include/mitsuba/render/microfacet.h`` (``eval_transmittance``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    clamp,
    dot,
    is_abstract,
    namespace,
    normalize,
    safe_div,
    to_numpy,
)
from brdfkit.brdf._microfacet_sampling import normal_pdf, sample_normal
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    ROUGHNESS,
    Sample,
    mixture_choices,
    normalized_weights,
    register,
    zero_unless,
)
from brdfkit.brdf.microfacet import MASKINGS, masking_shadowing
from brdfkit.brdf.microfacet_reflection import DISTRIBUTIONS, stretched_distribution
from brdfkit.brdf.phong import reflect_about
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel, fresnel_dielectric
from brdfkit.params import Domain, check_choice, param
from brdfkit.sampling import (
    square_to_cosine_hemisphere,
    square_to_cosine_hemisphere_pdf,
    square_to_uniform_disk_concentric,
)

INTERNAL = ("exact", "mitsuba")
"""How the coating's internal diffuse reflectance is computed: by quadrature (``"exact"``), or
as Mitsuba 3 does (``"mitsuba"``: the Egan–Hilgeman / d'Eon–Irving fits for ``plastic``, a
64-point rectangle rule over μ for ``roughplastic``)."""

COATING_IOR = Domain(1.0, 100.0, lo_open=True, hint="relative index of the coating, > 1")
"""The coating's relative index η = n_coating / n_outside: (1, 100]."""

TABLE_SIZE = 64
"""Entries of the rough coating's transmittance table over μ ∈ [0, 1] (Mitsuba's
``MI_ROUGH_TRANSMITTANCE_RES``)."""

_QUADRATURE = 32  # Mitsuba's Gauss–Legendre points per axis of the visible-normal square
_INTERNAL_QUADRATURE = 128  # Mitsuba's, from inside (η < 1: total internal reflection)
_EXACT_QUADRATURE = 64  # brdfkit's (T to ≤ 3e-5 absolute against 256² points for α ≥ 0.05)
_MU_QUADRATURE = 48  # Gauss–Legendre points in μ of the exact diffuse reflectances


@functools.lru_cache(maxsize=16)
def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1), 0.5 * w


def diffuse_fresnel_reflectance(eta: float, method: str = "exact") -> float:
    r"""The diffuse (hemispherical–hemispherical) Fresnel reflectance
    :math:`\bar F(\eta) = \int_0^1 F(\mu; \eta)\,2\mu\,d\mu` of a smooth interface of relative
    index η, for light arriving from the side of index 1.

    ``"exact"`` integrates by Gauss–Legendre quadrature: directly for η ≥ 1 (F is smooth), and
    for η < 1 (light inside a denser medium, total internal reflection beyond the critical
    angle) through :math:`\bar F(\eta) = 1 - \eta^2(1 - \bar F(1/\eta))`. ``"mitsuba"`` is
    Mitsuba 3's ``fresnel_diffuse_reflectance``: the Egan–Hilgeman (1973) fit for η < 1 and
    the d'Eon–Irving (2011) fit for η ≥ 1 (≤ 0.1 % relative error for η ∈ [1, 2]).
    """
    check_choice("method", method, INTERNAL)
    if method == "mitsuba":
        if eta < 1:
            return 0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
        x = 1 / eta
        coefficients = (0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881)
        return float(sum(c * x**k for k, c in enumerate(coefficients)))
    if eta < 1:
        return 1 - eta * eta * (1 - diffuse_fresnel_reflectance(1 / eta))
    mu, w = _gauss_legendre(_MU_QUADRATURE)
    return float(np.sum(w * np.asarray(fresnel_dielectric(mu, eta)) * 2 * mu))


def _mitsuba_ggx_visible_normals(wi: np.ndarray, u: np.ndarray, alpha: float) -> np.ndarray:
    """GGX normals visible from ``wi`` (in the xz-plane, isotropic α) by Mitsuba 3's map of the
    square (``sample_visible_11``: the concentric disk, Heitz & d'Eon 2014), only for
    reproducing Mitsuba's quadrature of the coating tables (``internal="mitsuba"``)."""
    wi_p = wi * np.array([alpha, alpha, 1.0])
    wi_p = wi_p / np.linalg.norm(wi_p, axis=-1, keepdims=True)
    cos_theta = wi_p[..., 2]
    p = square_to_uniform_disk_concentric(u)
    s = 0.5 * (1 + cos_theta)
    px = p[..., 0]
    py = np.sqrt(np.maximum(1 - px * px, 0.0)) * (1 - s) + p[..., 1] * s
    z = np.sqrt(np.maximum(1 - px * px - py * py, 0.0))
    sin_theta = np.sqrt(np.maximum(1 - cos_theta * cos_theta, 0.0))
    norm = 1 / (sin_theta * py + cos_theta * z)
    slope_x = (cos_theta * py - sin_theta * z) * norm * alpha
    slope_y = px * norm * alpha
    m = np.stack([-slope_x, -slope_y, np.ones_like(slope_x)], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def _rough_interface(
    distribution: str,
    alpha: float,
    approximate_g1: bool,
    eta: float,
    mu: np.ndarray,
    nodes: int,
    mitsuba_map: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    r"""Single-scattering reflectance and transmittance of a rough dielectric interface lit
    from the side of index 1 (relative index ``eta``) at cosines ``mu``: the integrals over the
    normals visible from ωi of :math:`F\,G_1(\omega_r)` and :math:`(1 - F)\,G_1(\omega_t)`, by
    ``nodes``² Gauss–Legendre points over the unit square of the visible-normal sampler (as
    Mitsuba 3's ``eval_reflectance``/``eval_transmittance``; ``mitsuba_map`` uses its GGX map
    of the square)."""
    ndf = stretched_distribution(distribution, alpha, None, None, approximate_g1)
    x, w = _gauss_legendre(nodes)
    u = np.stack(np.meshgrid(x, x, indexing="ij"), axis=-1).reshape(-1, 2)
    weight = np.outer(w, w).reshape(-1)
    wi = np.stack([np.sqrt(1 - mu * mu), np.zeros_like(mu), mu], axis=-1)[:, None, :]
    wi_b = np.broadcast_to(wi, (len(mu), len(u), 3))
    if mitsuba_map and distribution == "ggx":
        m = _mitsuba_ggx_visible_normals(wi_b, u, alpha)
    else:
        m = ndf.sample_visible(wi_b, u)
    cos_im = dot(wi, m, keepdims=True)
    f, cos_t, _, eta_ti = fresnel(cos_im, eta)
    wr = reflect_about(wi, m)
    wt = m * (cos_im * eta_ti + cos_t) - wi * eta_ti
    g_r = ndf.G1(wr, m)[..., 0] * f[..., 0]
    g_r = np.where((wr[..., 2] > 0) & (wi[..., 2] > 0), g_r, 0.0)
    g_t = ndf.G1(wt, m)[..., 0] * (1 - f[..., 0])
    g_t = np.where(wt[..., 2] * wi[..., 2] < 0, g_t, 0.0)
    return g_r @ weight, g_t @ weight


@functools.lru_cache(maxsize=64)
def rough_coating(
    distribution: str,
    alpha: float,
    eta: float,
    approximate_g1: bool = False,
    internal: str = "exact",
) -> tuple[np.ndarray, float]:
    r"""The rough coating's transmittance table and internal diffuse reflectance (cached).

    ``internal="exact"`` integrates over 64² visible normals (T to ≤ 3·10⁻⁵ against 256²) and
    :math:`\bar F_{int}` by 48-point Gauss–Legendre in μ; ``"mitsuba"`` reproduces Mitsuba 3's
    numerics: 32² points (128² from inside) through its GGX map of the square, and
    :math:`\bar F_{int} = 2\,\mathrm{mean}_k(R_{int}(\mu_k)\mu_k)` over the table's 64 nodes,
    a rectangle rule ~1.5 % below the integral (total internal reflection makes
    :math:`R_{int}` kink at the critical angle).

    Returns
    -------
    table : (:data:`TABLE_SIZE`,) transmittance :math:`T(\mu)` at μ = linspace(0, 1) (the first
        node at 10⁻⁶), from outside, interpolated linearly by the model.
    internal_reflectance : :math:`\bar F_{int} = \int_0^1 R_{int}(\mu)\,2\mu\,d\mu`, the
        reflectance from inside (index ratio 1/η).
    """
    mu = np.maximum(1e-6, np.linspace(0.0, 1.0, TABLE_SIZE))
    args = (distribution, alpha, approximate_g1)
    if internal == "mitsuba":
        _, table = _rough_interface(*args, eta, mu, _QUADRATURE, mitsuba_map=True)
        r_int, _ = _rough_interface(*args, 1 / eta, mu, _INTERNAL_QUADRATURE, mitsuba_map=True)
        return table, float(2 * np.mean(r_int * mu))
    _, table = _rough_interface(*args, eta, mu, _EXACT_QUADRATURE)
    nodes, weights = _gauss_legendre(_MU_QUADRATURE)
    r_int, _ = _rough_interface(*args, 1 / eta, nodes, _EXACT_QUADRATURE)
    return table, float(np.sum(weights * r_int * 2 * nodes))


def _lerp_table(table: np.ndarray, cos_theta: Array) -> Array:
    r"""``table`` (over μ = linspace(0, 1)) interpolated linearly at ``cos_theta``, as Mitsuba's
    ``lerp_gather``; ``cos_theta`` is ``(..., 1)`` and so is the result.

    Under JAX tracing (``jax.jit``, :func:`brdfkit.compiled.compile`, which has no gather) the
    same interpolant is summed from ramps, :math:`T_0 + \sum_k (T_{k+1} - T_k)
    \,\mathrm{clip}(x - k, 0, 1)`; elsewhere it is gathered.
    """
    xp = namespace(cos_theta)
    size = table.shape[0]
    x = clamp(cos_theta, 0.0, 1.0) * (size - 1)
    if is_abstract(cos_theta):
        steps = np.diff(table)
        value = xp.zeros_like(x) + float(table[0])
        for k, step in enumerate(steps):
            value = value + float(step) * clamp(x - k, 0.0, 1.0)
        return value
    index = xp.minimum(xp.floor(x), xp.asarray(size - 2, dtype=x.dtype))
    t = x - index
    flat = xp.reshape(xp.astype(index, xp.int64), (-1,))
    values = asarray(table, xp, like=cos_theta, dtype=cos_theta.dtype)
    v0 = xp.reshape(xp.take(values, flat), x.shape)
    v1 = xp.reshape(xp.take(values, flat + 1), x.shape)
    return v0 + (v1 - v0) * t


class _Plastic(BRDF):
    """What the smooth and rough plastic share: parameters, ρ', the lobe probabilities."""

    diffuse_reflectance: Any
    specular_reflectance: Any
    eta: Any
    nonlinear: bool
    internal: str
    reciprocal: ClassVar[bool] = True
    energy_conserving: ClassVar[bool] = True
    choices: ClassVar[dict[str, tuple[str, ...]]] = {"internal": INTERNAL}

    def __post_init__(self) -> None:
        super().__post_init__()
        if np.size(to_numpy(self.eta)) != 1:
            raise ParameterError(
                "eta must be one number (the coating's index, no dispersion); got shape "
                f"{np.shape(to_numpy(self.eta))}"
            )

    def _channel_values(self) -> dict[str, Any]:
        """The reflectances (η and α are one number each)."""
        return {
            "diffuse_reflectance": self.diffuse_reflectance,
            "specular_reflectance": self.specular_reflectance,
        }

    def _eta(self) -> float:
        return float(np.reshape(to_numpy(self.eta), ()))

    def _rho(self, like: Array, internal_reflectance: float) -> Array:
        """ρ' = ρ/(1 − F̄int), or ρ/(1 − ρF̄int) when nonlinear."""
        rho = param(self.diffuse_reflectance, like)
        if self.nonlinear:
            return rho / (1 - rho * internal_reflectance)
        return rho / (1 - internal_reflectance)

    def _specular_probability(self, specular_albedo: Array, wo: Array) -> Array:
        """Mitsuba's choice of the specular lobe, ``(...,)``: ∝ its albedo estimate times
        s̄/(ρ̄ + s̄), against the diffuse's (1 − that) times ρ̄/(ρ̄ + s̄) (means over channels)."""
        xp = namespace(wo)
        zero = xp.zeros_like(wo[..., 0])
        d_mean = xp.mean(param(self.diffuse_reflectance, wo), axis=-1) + zero
        s_mean = xp.mean(param(self.specular_reflectance, wo), axis=-1) + zero
        weight = safe_div(s_mean, d_mean + s_mean)
        specular, _ = normalized_weights(
            [specular_albedo * weight, (1 - specular_albedo) * (1 - weight)]
        )
        return specular


_DOMAINS: dict[str, Domain] = {
    "diffuse_reflectance": ALBEDO,
    "specular_reflectance": ALBEDO,
    "eta": COATING_IOR,
}


@register("plastic")
@dataclass(frozen=True, eq=False)
class SmoothPlastic(_Plastic):
    r"""A diffuse base under a smooth dielectric coating (Mitsuba 3's ``plastic``).

    .. math::
        f_r = s\,F(\cos\theta_o)\,\frac{\delta_{\omega_r}(\omega_i)}{\cos\theta_i}
            + \frac{\rho'}{\pi\eta^2}(1 - F(\cos\theta_i))(1 - F(\cos\theta_o)),

    the module's diffuse part with the smooth interface's :math:`T = 1 - F` (exact dielectric
    Fresnel) and a mirror lobe of albedo s F(θo), a delta seen only by ``sample``.
    ``internal="mitsuba"`` takes :math:`\bar F_{int}` from Mitsuba's fits (≤ 0.1 % off the
    exact integral for η ≤ 2; the diffuse part then differs by up to ~0.2 %).

    Reciprocal: yes. Energy-conserving: yes for ρ, s ≤ 1 — the albedo is
    :math:`sF(\theta_o) + (1 - F(\theta_o))\rho(1 - \bar F_{int})/(1 - \bar F_{int})`
    (:math:`\rho` replaced by :math:`\rho(1-\bar F_{int})/(1-\rho\bar F_{int})` when
    nonlinear), since :math:`\int(1-F)\cos\theta_i\,d\omega_i/(\pi\eta^2) = 1 - \bar
    F_{int}`.

    Sampled as Mitsuba: the mirror with probability ∝ F(θo) s̄/(ρ̄ + s̄), else the cosine
    hemisphere; ``pdf`` is the diffuse part's (the mirror is a delta).

    Parameters
    ----------
    diffuse_reflectance : ρ ∈ [0, 1] (per channel; default 0.5).
    specular_reflectance : s ∈ [0, 1], a factor on the coating's reflection (default 1).
    eta : the coating's relative index η ∈ (1, 100] (default 1.49, polypropylene, Mitsuba's).
    nonlinear : the inter-reflection series ρ/(1 − ρF̄int) instead of ρ/(1 − F̄int).
    internal : ``"exact"`` (default) or ``"mitsuba"`` (:data:`INTERNAL`).

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``src/bsdfs/plastic.cpp``.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §14.3
           (layered BSDFs).

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import SmoothPlastic
    >>> f = SmoothPlastic(diffuse_reflectance=0.5, eta=1.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1602])
    >>> s = f.sample(np.array([-0.48, -0.36, 0.8]), np.array([0.01, 0.5]))
    >>> s.wi, np.round(s.weight, 4), bool(s.delta)
    (array([0.48, 0.36, 0.8 ]), array([0.5219]), True)
    """

    diffuse_reflectance: Any = 0.5
    specular_reflectance: Any = 1.0
    eta: Any = 1.49
    nonlinear: bool = False
    internal: str = "exact"
    has_delta: ClassVar[bool] = True
    domains: ClassVar[dict[str, Domain]] = _DOMAINS

    def __post_init__(self) -> None:
        super().__post_init__()
        eta = self._eta()
        object.__setattr__(
            self, "internal_reflectance", diffuse_fresnel_reflectance(1 / eta, self.internal)
        )

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(diffuse_reflectance=[0.8, 0.3, 0.1], eta=1.5),
            cls(diffuse_reflectance=0.9, eta=2.0, nonlinear=True),
            cls(diffuse_reflectance=[0.2, 0.6, 0.3], specular_reflectance=0.5, eta=1.33),
        ]

    def _fresnel(self, cos_theta: Array) -> Array:
        return fresnel_dielectric(clamp(cos_theta, 0.0, 1.0), param(self.eta, cos_theta))

    def _eval(self, wi: Array, wo: Array) -> Array:
        rho = self._rho(wi, self.internal_reflectance)
        eta = param(self.eta, wi)
        t_i = 1 - self._fresnel(wi[..., 2:3])
        t_o = 1 - self._fresnel(wo[..., 2:3])
        return rho * (t_i * t_o / (math.pi * eta * eta))

    def _probability(self, wo: Array) -> Array:
        return self._specular_probability(self._fresnel(wo[..., 2:3])[..., 0], wo)

    def _pdf(self, wi: Array, wo: Array) -> Array:
        return (1 - self._probability(wo)) * square_to_cosine_hemisphere_pdf(wi)

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        u = asarray(u, xp, like=wo)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo = xp.broadcast_to(wo, (*batch, 3))
        p_specular = self._probability(wo)
        (pick_s, _), (_, u_d) = mixture_choices([p_specular, 1 - p_specular], u)
        mirror = xp.concat([-wo[..., 0:1], -wo[..., 1:2], wo[..., 2:3]], axis=-1)
        wi = xp.where(pick_s[..., None], mirror, square_to_cosine_hemisphere(u_d[..., :2]))
        pdf = self.pdf(wi, wo)
        # a denormal density is a far tail, where f cos θi / p would overflow: failed
        ok = pdf > xp.finfo(pdf.dtype).smallest_normal
        f = self.eval(wi, wo)
        diffuse_w = f * (wi[..., 2] / xp.where(ok, pdf, xp.ones_like(pdf)))[..., None]
        specular = param(self.specular_reflectance, wo) * self._fresnel(wo[..., 2:3])
        safe_p = xp.where(p_specular > 0, p_specular, xp.ones_like(p_specular))
        specular_w = xp.broadcast_to(specular / safe_p[..., None], f.shape)
        weight = xp.where(pick_s[..., None], specular_w, diffuse_w)
        pdf = xp.where(pick_s | ~ok, xp.zeros_like(pdf), pdf)
        return Sample(wi, weight, pdf, pick_s & (wo[..., 2] > 0))

    def _sampling_weight(self, wo: Array) -> Array:
        xp = namespace(wo)
        f = self._fresnel(wo[..., 2:3])
        s = param(self.specular_reflectance, wo)
        rho = param(self.diffuse_reflectance, wo)
        return xp.mean(s * f + (1 - f) * rho, axis=-1)


@register("rough_plastic")
@dataclass(frozen=True, eq=False)
class RoughPlastic(_Plastic):
    r"""A diffuse base under a rough dielectric coating (Mitsuba 3's ``roughplastic``).

    .. math::
        f_r = s\,\frac{F(\omega_i\cdot\omega_h)\,D(\omega_h)\,G(\omega_i,\omega_o,
            \omega_h)}{4\cos\theta_i\cos\theta_o}
            + \frac{\rho'}{\pi\eta^2}\,T(\cos\theta_i)\,T(\cos\theta_o),

    a GGX or Beckmann microfacet coating over the module's diffuse part, where :math:`T(\mu)`
    is the rough interface's single-scattering transmittance — the integral over the normals
    visible from ω of :math:`(1 - F)\,G_1(\omega_t)` — computed by brdfkit (32×32
    Gauss–Legendre over the visible-normal square, tabulated at 64 cosines and interpolated
    linearly, as Mitsuba's ``rough_transmittance``; :func:`rough_coating`, cached). Brdfkit's
    GGX visible-normal map is Heitz (2018)'s polar one where Mitsuba's is the concentric disk:
    the same integral, with different quadrature error. :math:`\bar F_{int}` is the rough
    interface's diffuse reflectance from inside, by Gauss–Legendre in μ (``"exact"``) or
    Mitsuba's 64-point rectangle rule (``"mitsuba"``, a few 10⁻³ off; use it to match Mitsuba).

    Reciprocal: yes. Energy-conserving: yes for ρ, s ≤ 1 (the coating's single scattering
    loses energy; the diffuse albedo is at most ρ T(θo)(1 − F̄ext)/(η²(1 − F̄int)) ≤ ρ T(θo)).

    Sampled as Mitsuba: the microfacet lobe (visible normals) with probability ∝
    (1 − T(θo)) s̄/(ρ̄ + s̄), else the cosine hemisphere.

    Parameters
    ----------
    alpha : the coating's isotropic roughness in [10⁻⁴, 10] (one number; default 0.1).
    distribution : ``"beckmann"`` (default, as Mitsuba) or ``"ggx"``.
    diffuse_reflectance, specular_reflectance, eta, nonlinear, internal : as
        :class:`SmoothPlastic`.
    masking : ``"smith_separable"`` (default, Mitsuba's), ``"smith_correlated"`` or
        ``"v_groove"``.
    approximate_g1 : Beckmann only — Walter's rational G1, as Mitsuba (default False).

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``src/bsdfs/roughplastic.cpp``.
    .. [2] C. Kelemen, L. Szirmay-Kalos, Eurographics 2001.
    .. [3] B. Walter et al., EGSR 2007.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import RoughPlastic
    >>> f = RoughPlastic(alpha=0.1, diffuse_reflectance=0.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1597])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    alpha: Any = 0.1
    distribution: str = "beckmann"
    diffuse_reflectance: Any = 0.5
    specular_reflectance: Any = 1.0
    eta: Any = 1.49
    nonlinear: bool = False
    internal: str = "exact"
    masking: str = "smith_separable"
    approximate_g1: bool = False
    domains: ClassVar[dict[str, Domain]] = {**_DOMAINS, "alpha": ROUGHNESS}
    choices: ClassVar[dict[str, tuple[str, ...]]] = {
        "distribution": DISTRIBUTIONS,
        "masking": MASKINGS,
    }

    def __post_init__(self) -> None:
        super().__post_init__()
        if np.size(to_numpy(self.alpha)) != 1:
            raise ParameterError(
                "alpha must be one number (the coating's roughness is tabulated); got shape "
                f"{np.shape(to_numpy(self.alpha))}"
            )
        alpha = float(np.reshape(to_numpy(self.alpha), ()))
        ndf = stretched_distribution(self.distribution, alpha, None, None, self.approximate_g1)
        table, internal = rough_coating(
            self.distribution, alpha, self._eta(), self.approximate_g1, self.internal
        )
        object.__setattr__(self, "ndf", ndf)
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "internal_reflectance", internal)

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(alpha=0.3, distribution="ggx", diffuse_reflectance=[0.8, 0.3, 0.1], eta=1.5),
            cls(alpha=0.05, distribution="ggx", diffuse_reflectance=0.9, nonlinear=True),
            cls(alpha=0.6, diffuse_reflectance=[0.2, 0.6, 0.3], specular_reflectance=0.5),
        ]

    def _transmittance(self, cos_theta: Array) -> Array:
        return _lerp_table(self.table, cos_theta)

    def _specular(self, wi: Array, wo: Array) -> Array:
        """The coating's microfacet reflection, s F D G / (4 cos θi cos θo)."""
        h = normalize(wi + wo)
        d = self.ndf.D(h)
        g = masking_shadowing(self.ndf, wi, wo, h, self.masking)
        f = fresnel_dielectric(clamp(dot(wo, h, keepdims=True), -1.0, 1.0), param(self.eta, wi))
        return (
            param(self.specular_reflectance, wi)
            * f
            * safe_div(d * g, 4 * wi[..., 2:3] * wo[..., 2:3])
        )

    def _eval(self, wi: Array, wo: Array) -> Array:
        rho = self._rho(wi, self.internal_reflectance)
        eta = param(self.eta, wi)
        t_i = self._transmittance(wi[..., 2:3])
        t_o = self._transmittance(wo[..., 2:3])
        diffuse = rho * (t_i * t_o / (math.pi * eta * eta))
        return self._specular(wi, wo) + diffuse

    def _probability(self, wo: Array) -> Array:
        return self._specular_probability(1 - self._transmittance(wo[..., 2:3])[..., 0], wo)

    def _pdf(self, wi: Array, wo: Array) -> Array:
        p_specular = self._probability(wo)
        h = normalize(wi + wo)
        wo_h = dot(wo, h)
        specular = safe_div(normal_pdf(self.ndf, True, wo, h), 4 * wo_h)
        value = p_specular * specular + (1 - p_specular) * square_to_cosine_hemisphere_pdf(wi)
        return zero_unless(wo_h > 0, value)

    def _sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        u = asarray(u, xp, like=wo)
        p_specular = self._probability(wo)
        (pick_s, u_s), (_, u_d) = mixture_choices([p_specular, 1 - p_specular], u)
        wi_s = reflect_about(wo, sample_normal(self.ndf, True, wo, u_s))
        wi_d = square_to_cosine_hemisphere(u_d[..., :2])
        wi_s, wi_d = xp.broadcast_arrays(wi_s, wi_d)
        wi = xp.where(pick_s[..., None], wi_s, wi_d)
        wi, wo = xp.broadcast_arrays(wi, wo)
        pdf = self.pdf(wi, wo)
        # a denormal density is a far tail, where f cos θi / p would overflow: failed
        ok = pdf > xp.finfo(pdf.dtype).smallest_normal
        safe_pdf = xp.where(ok, pdf, xp.ones_like(pdf))
        weight = self.eval(wi, wo) * (wi[..., 2] / safe_pdf)[..., None]
        return Sample(wi, weight, xp.where(ok, pdf, xp.zeros_like(pdf)), False)

    def _sampling_weight(self, wo: Array) -> Array:
        xp = namespace(wo)
        t = self._transmittance(wo[..., 2:3])
        s = param(self.specular_reflectance, wo)
        rho = param(self.diffuse_reflectance, wo)
        return xp.mean(s * (1 - t) + t * rho, axis=-1)


__all__ = [
    "COATING_IOR",
    "INTERNAL",
    "TABLE_SIZE",
    "RoughPlastic",
    "SmoothPlastic",
    "diffuse_fresnel_reflectance",
    "rough_coating",
]
