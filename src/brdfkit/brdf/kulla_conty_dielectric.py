r"""Kulla & Conty's (2017) energy compensation for rough GGX dielectrics: reflection and
transmission, both sides of the interface.

A single-scattering microfacet dielectric (:class:`~brdfkit.brdf.RoughDielectric`, GGX,
height-correlated Smith) loses the light that meets the microsurface more than once: from
the view direction ωo on side s (outside, index 1, or inside, index η) its reflected plus
transmitted flux albedo is :math:`E_s(\mu_o) < 1`. Kulla & Conty add a separable lobe that
returns :math:`1 - E_s(\mu_o)`, split between reflection (back to side s) and transmission.

With the generalised reciprocity of refraction (Veach 1997 §5.2) written as a symmetric
kernel :math:`K(\omega_i,\omega_o) = f(\omega_i,\omega_o)/n_o^2` (radiance mode;
:math:`f = n_i^2 K` in importance mode), the added kernel is

.. math::
    K_{ms} = \frac{a_s(\mu_i)\,a_s(\mu_o)}{\pi\,n_s^2\,A_s}\ \text{(reflection, side s)},
    \qquad
    K_{ms} = \frac{b_{out}(\mu_{out})\,b_{in}(\mu_{in})}{\pi\,B_{out}}\ \text{(transmission)},

with :math:`a_s = x_s(1 - E_s)` the reflected and :math:`b_s` the transmitted share of the
lost energy, :math:`A_s = 2\int_0^1 a_s\,\mu\,d\mu` (and :math:`B_s` likewise). Its flux
albedo from side s is then :math:`a_s(\mu_o) + b_s(\mu_o) = 1 - E_s(\mu_o)` exactly, provided
:math:`\eta^2 B_{in} = B_{out}`: the transmitted flux, averaged over the hemisphere, obeys
the same reciprocity as a smooth interface's :math:`1 - \bar F(1/\eta) = (1 - \bar F(\eta))/
\eta^2`. This is the reciprocity correction of the transmission term (the role it plays in
Kulla & Conty's dielectrics): the rarer side's transmitted share (for η > 1 the outside's,
:math:`b_{out} = (1 - x_{out})(1 - E_{out})`) is kept and the denser side's scaled to match,
:math:`b_{in} = \kappa(1 - x_{in})(1 - E_{in})` with :math:`\kappa = B_{out}/(\eta^2 B_{in})`
(≤ 1 − E_in), its reflected share the rest, :math:`a_{in} = 1 - E_{in} - b_{in}`.

The split :math:`x_s` (``split=``):

- ``"fresnel_average"``: Kulla & Conty's, :math:`x = \bar F(\max(\eta, 1/\eta))` on the
  rarer side (the hemispherical average Fresnel reflectance,
  :func:`brdfkit.brdf.plastic.diffuse_fresnel_reflectance`) and the denser side's
  transmission :math:`\propto 1 - E`, fixed by the correction above. The
  random walk shows that multiply scattered light from outside is transmitted far more often
  than :math:`1 - \bar F`: at α = 1, η = 1.5, θo = 0 the reflected albedo is then 0.0225
  against the walk's 0.0156 (+44 %), and from inside R is up to 20 % high and T up to 15 %
  low (``benchmarks/kulla_conty_dielectric_accuracy.py``), though R + T is right.
- ``"random_walk"`` (default): :math:`x_s(\mu)`, the fraction of the multiply scattered paths
  of Heitz et al.'s (2016) dielectric random walk that leave on the side they came from
  (:func:`split_table`, shipped, tabulated over (α, ln η, √μ) for both sides), so that R
  and T each match the walk.

:math:`E_s(\mu)` is computed by brdfkit for each (α, η) by deterministic quadrature over the
visible normals (:func:`dielectric_albedo`) and kept as a Chebyshev series in √μ
(:func:`albedo_series`, cached in memory).

References
----------
.. [1] C. Kulla, A. Conty, "Revisiting physically based shading at Imageworks", SIGGRAPH 2017
       course *Physically Based Shading in Theory and Practice* (dielectrics: E and E_avg for
       η and 1/η, the split by the average Fresnel, the reciprocity of the transmission).
.. [2] E. Heitz, J. Hanika, E. d'Eon, C. Dachsbacher, "Multiple-scattering microfacet BSDFs
       with the Smith model", ACM TOG 35(4), 2016 (the dielectric random walk).
.. [3] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
       through rough surfaces", EGSR 2007.
.. [4] E. Veach, PhD thesis, Stanford, 1997, §5.2 (non-symmetric scattering at refraction).
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from importlib.resources import files
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, clamp, dot, namespace, to_numpy
from brdfkit.brdf._microfacet_sampling import sample_normal
from brdfkit.brdf.base import (
    BRDF,
    Sample,
    mixture_choices,
    normalized_weights,
    per_direction,
    register,
)
from brdfkit.brdf.kulla_conty import (
    COMPENSATED_ROUGHNESS,
    DEGREE,
    QUADRATURE_NODES,
    _clenshaw,
    chebyshev_nodes,
    chebyshev_weights,
    visible_normal_quadrature,
)
from brdfkit.brdf.microfacet_reflection import defined_params
from brdfkit.brdf.plastic import diffuse_fresnel_reflectance
from brdfkit.brdf.random_walk import dielectric_random_walk_albedo
from brdfkit.brdf.rough_dielectric import RoughDielectric
from brdfkit.brdf.specular import MODES, check_scalar_eta, interface_sampling_weight
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel
from brdfkit.params import Domain, param
from brdfkit.sampling import square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf

ETA_RANGE = (1.1, 2.5)
"""The tabulated |relative index|: η ∈ [1.1, 2.5] or 1/η in it (water 1.33 to diamond 2.42)."""

COMPENSATED_IOR = Domain(1 / ETA_RANGE[1], ETA_RANGE[1], hint="n_inside / n_outside")
"""The relative index η of :class:`KullaContyDielectric`: [1/2.5, 2.5] with |ln η| ≥ ln 1.1
(checked in the constructor; near η = 1 the microfacet BTDF becomes a delta)."""

SPLIT_TABLE_AXES: dict[str, tuple[int, float, float]] = {
    "alpha": (10, COMPENSATED_ROUGHNESS.lo, COMPENSATED_ROUGHNESS.hi),
    "log_eta": (8, math.log(ETA_RANGE[0]), math.log(ETA_RANGE[1])),
    "s": (14, 0.0, 1.0),
}
"""Axes of the shipped split table (:func:`split_table`): (nodes, low, high) of Chebyshev
points in the roughness α, ln η (η > 1) and s = √μ."""

SPLIT_TABLE_PATHS = 1 << 17
"""Random-walk paths per (α, η, μ, side) node of the split table."""

SPLITS = ("random_walk", "fresnel_average")
"""The ways of splitting the compensated energy between reflection and transmission."""


def single_scattering(alpha: float, eta: float, mode: str = "importance") -> RoughDielectric:
    """The single-scattering lobe that is compensated: GGX, height-correlated Smith (the first
    order of Heitz et al.'s random walk), visible-normal sampling."""
    return RoughDielectric(alpha=alpha, eta=eta, masking="smith_correlated", mode=mode)


def dielectric_albedo(
    alpha: float, eta: float, mu: Any, nodes: tuple[int, int] = QUADRATURE_NODES
) -> np.ndarray:
    r"""Reflected and transmitted flux albedo of the single-scattering GGX dielectric
    (:func:`single_scattering`, importance mode) seen from ``mu`` = cos θo, any shape, > 0
    outside and < 0 inside: ``mu.shape + (2,)``, (R, T).

    Deterministic quadrature over the normals visible from ωo
    (:func:`~brdfkit.brdf.kulla_conty.visible_normal_quadrature`): at each normal ωm the
    lobe's own sampler reflects (weight :math:`w_R`) or refracts (:math:`w_T`), and
    :math:`E = \sum_m \text{weight}_m\,[F w_R + (1 - F) w_T]` with F = F(ωo·ωm) the
    probability the sampler gives each branch.
    """
    mu = np.asarray(mu, dtype=np.float64)
    u, weights = visible_normal_quadrature(nodes, mirror=True)  # ωo in the xz-plane
    flat = mu.reshape(-1)
    wo = np.stack([np.sqrt(np.clip(1 - flat * flat, 0, 1)), 0 * flat, flat], axis=-1)
    wo = np.broadcast_to(wo[:, None, :], (flat.size, u.shape[0], 3))
    model = single_scattering(alpha, eta)
    # the sampler's normals and Fresnel terms, made once for both branches
    h = sample_normal(model.ndf, True, wo, np.broadcast_to(u, (*wo.shape[:-1], 2)))
    terms = fresnel(dot(wo, h, keepdims=True), param(model.eta, wo))
    branches = []
    for u_choice in (0.0, 1.0):  # reflect wherever F > 0; refract unless F = 1
        u3 = np.concatenate([u, np.full((u.shape[0], 1), u_choice)], axis=-1)
        sample = model._sample_at_normal(wo, h, np.broadcast_to(u3, wo.shape), False, terms)
        branches.append(sample.weight[..., 0])
    f = terms[0][..., 0]
    albedo = np.stack([f * branches[0], (1 - f) * branches[1]], axis=-1)
    return np.einsum("pnk,n->pk", albedo, weights).reshape(*mu.shape, 2)


def _gauss_s(n: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes s ∈ (0, 1) and the weights of ∫ g(μ) 2μ dμ with μ = s²."""
    s, w = np.polynomial.legendre.leggauss(n)
    s, w = (s + 1) / 2, w / 2
    return s, 4 * w * s**3


@functools.lru_cache(maxsize=64)
def albedo_series(alpha: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Chebyshev coefficients, in :math:`x = 2\sqrt\mu - 1`, of the single-scattering flux
    albedo :math:`E(\mu) = R + T` of :func:`single_scattering` seen from outside and from
    inside, each ``(DEGREE + 1,)``; computed by :func:`dielectric_albedo` at the Chebyshev
    points and kept in memory."""
    x = np.cos(math.pi * (np.arange(DEGREE + 1) + 0.5) / (DEGREE + 1))
    mu = ((x + 1) / 2) ** 2
    e = dielectric_albedo(alpha, eta, np.concatenate([mu, -mu])).sum(axis=-1)
    outside, inside = e[: DEGREE + 1], e[DEGREE + 1 :]
    fit = functools.partial(np.polynomial.chebyshev.chebfit, x, deg=DEGREE)
    return fit(y=outside), fit(y=inside)


def split_node(i: int, j: int, k: int, paths: int = SPLIT_TABLE_PATHS) -> np.ndarray:
    r"""One (α, η, s) node ``(i, j, k)`` of :func:`split_table`, by the dielectric random walk
    (seeds ``10⁴ i + 100 j + k`` and + 5·10⁵): the multiply scattered albedo that leaves on
    the side it came from and on the other, ``(2, 2)``, from outside (relative index η > 1)
    and from inside (1/η)."""
    nodes = {name: chebyshev_nodes(*axis) for name, axis in SPLIT_TABLE_AXES.items()}
    alpha, eta, s = nodes["alpha"][i], math.exp(nodes["log_eta"][j]), nodes["s"][k]
    mu = s * s
    seed = 10_000 * i + 100 * j + k
    result = []
    for side, offset in ((1.0, 0), (-1.0, 500_000)):
        wo = np.array([math.sqrt(1 - mu * mu), 0.0, side * mu])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # 0 ** negative in the masking
            walk = dielectric_random_walk_albedo(
                float(alpha), eta, wo, paths=paths, seed=seed + offset
            )
        result.append(
            [walk.reflected - walk.reflected_single, walk.transmitted - walk.transmitted_single]
        )
    return np.array(result)


@functools.lru_cache(maxsize=1)
def split_table() -> np.ndarray:
    r"""The shipped table ``(alpha, log_eta, s, side, lobe)`` of the multiply scattered flux
    albedo of the GGX dielectric that is reflected (lobe 0) and transmitted (lobe 1), seen
    from the medium of lower index (side 0) or the denser one (side 1), at the Chebyshev
    nodes of :data:`SPLIT_TABLE_AXES` (Heitz et al.'s (2016) random walk, 2¹⁷ paths per
    node); regenerated by ``benchmarks/kulla_conty_dielectric_table.py``. Both vanish
    smoothly as α → 0, where their ratio would be noise: they are interpolated, then
    divided (:func:`split_series`)."""
    with (files("brdfkit.data") / "kulla_conty_dielectric.npz").open("rb") as handle:
        table = np.load(handle)["multiple"].astype(np.float64)
    expected = (*(n for n, _, _ in SPLIT_TABLE_AXES.values()), 2, 2)
    if table.shape != expected:  # pragma: no cover - a stale table
        raise RuntimeError(f"kulla_conty_dielectric.npz has shape {table.shape}, not {expected}")
    return table


def split_series(alpha: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Chebyshev coefficients in :math:`x = 2\sqrt\mu - 1` of the reflected fraction
    :math:`x_s(\mu)` of the multiply scattered light, from outside and from inside of the
    interface (α, η): the reflected and transmitted albedos of :func:`split_table`
    interpolated in α and ln|η| (tensor Chebyshev), divided, then a series in s."""
    weights_alpha = chebyshev_weights(alpha, *SPLIT_TABLE_AXES["alpha"])
    weights_eta = chebyshev_weights(abs(math.log(eta)), *SPLIT_TABLE_AXES["log_eta"])
    at_s = np.maximum(np.einsum("aeskl,a,e->skl", split_table(), weights_alpha, weights_eta), 0)
    total = at_s.sum(axis=-1)
    fraction = np.where(total > 0, at_s[..., 0] / np.where(total > 0, total, 1.0), 0.5)
    if eta < 1:  # outside is the denser medium
        fraction = fraction[:, ::-1]
    n_s, _, _ = SPLIT_TABLE_AXES["s"]
    x_nodes = 2 * chebyshev_nodes(n_s, 0.0, 1.0) - 1
    outside, inside = np.polynomial.chebyshev.chebfit(x_nodes, fraction, n_s - 1).T
    return outside, inside


@register("kulla_conty_dielectric")
@dataclass(frozen=True, eq=False)
class KullaContyDielectric(BRDF):
    r"""A rough GGX dielectric with Kulla & Conty's (2017) multiple-scattering compensation
    of reflection and transmission (module docstring for the formulas).

    .. math::
        f = f_{ss} + n^2 K_{ms},\qquad \int (f_R + f_T)\,|\cos\theta_i|\,d\omega_i = 1
        \ \text{(importance mode)},

    :math:`f_{ss}` the Walter et al. (2007) BSDF (:class:`~brdfkit.brdf.RoughDielectric`, GGX,
    height-correlated Smith), :math:`K_{ms}` the separable kernel of the module docstring and
    :math:`n^2` the squared index on the side of ωo (radiance mode) or of ωi (importance).

    **Reciprocal**: in the generalised form of refraction,
    :math:`f(\omega_i,\omega_o)/n_o^2 = f(\omega_o,\omega_i)/n_i^2` (radiance mode; the added
    kernel is symmetric by construction, reflection plainly reciprocal), not plainly.
    **Energy-conserving**: yes: without absorption the flux albedo R + T is 1 to the accuracy
    of E(μ) (tested ≤ 0.5 % for α ∈ [0.05, 1], θ < 85°, both sides, η ∈ [1.1, 2.5] and
    1/1.5; measured worst 3.1·10⁻³ at η = 1.1, α = 1, normal view from inside). R and T
    each agree with Heitz et al.'s (2016) random walk on the same microsurface
    (``split="random_walk"``, independent seeds) within 2 % wherever 2¹⁷ paths resolve 2 %
    (measured worst 1.7 %); a small R (a few %, from outside) can be off by a few 10⁻⁴
    more, the noise of the walk-built table (``benchmarks/kulla_conty_dielectric_accuracy.py``).
    What is matched is the directional albedo of the multiply scattered light; its angular
    distribution is the separable lobes', not the walk's.

    Sampled by a mixture of the single-scattering lobe's sampler and cosine-weighted
    hemispheres on both sides, chosen in proportion to their flux albedos at ``wo``.

    Parameters
    ----------
    alpha : isotropic GGX roughness in [0.01, 1] (a scalar: E is computed per value).
    eta : relative index n_inside / n_outside, 1.1 ≤ η ≤ 2.5 or 1/2.5 ≤ η ≤ 1/1.1 (scalar).
    split : ``"random_walk"`` (default) or ``"fresnel_average"`` (Kulla & Conty's, module
        docstring).
    mode : ``"radiance"`` (default) or ``"importance"``, as
        :class:`~brdfkit.brdf.RoughDielectric`.

    References
    ----------
    .. [1] C. Kulla, A. Conty, "Revisiting physically based shading at Imageworks", SIGGRAPH
           2017 course *Physically Based Shading in Theory and Practice*.
    .. [2] E. Heitz, J. Hanika, E. d'Eon, C. Dachsbacher, "Multiple-scattering microfacet
           BSDFs with the Smith model", ACM TOG 35(4), 2016.
    .. [3] B. Walter et al., "Microfacet models for refraction through rough surfaces", EGSR
           2007.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import KullaContyDielectric
    >>> f = KullaContyDielectric(alpha=0.5, eta=1.5, mode='importance')
    >>> n = np.array([0.0, 0.0, 1.0])
    >>> np.round(f.eval(n, n), 4)
    array([0.0131])
    >>> np.round(f.albedo_estimate(n, hemisphere='both')[0], 2)
    array([1.])
    """

    alpha: Any = 0.5
    eta: Any = 1.5
    split: str = "random_walk"
    mode: str = "radiance"

    transmits = True
    reciprocal = False
    domains: ClassVar[dict[str, Domain]] = {"alpha": COMPENSATED_ROUGHNESS, "eta": COMPENSATED_IOR}
    choices: ClassVar[dict[str, tuple[str, ...]]] = {"split": SPLITS, "mode": MODES}

    def __post_init__(self) -> None:
        super().__post_init__()
        check_scalar_eta(self.eta)
        alpha = np.asarray(to_numpy(self.alpha), dtype=np.float64)
        if alpha.size != 1:
            raise ParameterError(
                f"alpha must be a scalar for kulla_conty_dielectric (E is computed per value); "
                f"got shape {alpha.shape}"
            )
        alpha, eta = float(alpha.reshape(())), float(np.asarray(to_numpy(self.eta)).reshape(()))
        if abs(math.log(eta)) < math.log(ETA_RANGE[0]):
            raise ParameterError(
                f"eta must be ≥ {ETA_RANGE[0]} or ≤ 1/{ETA_RANGE[0]} for kulla_conty_dielectric "
                f"(the tabulated range); got {eta}"
            )
        single = single_scattering(self.alpha, self.eta, self.mode)
        e_series = albedo_series(alpha, eta)  # (outside, inside)
        if self.split == "random_walk":
            x_series = split_series(alpha, eta)
        else:  # Kulla & Conty: F̄ reflected from the rarer side, the denser side ∝ 1 − E
            rare = np.array([diffuse_fresnel_reflectance(max(eta, 1 / eta))])
            x_series = (rare, np.zeros(1)) if eta > 1 else (np.zeros(1), rare)
        s, w = _gauss_s()

        def series(c: np.ndarray) -> np.ndarray:
            return np.clip(np.polynomial.chebyshev.chebval(2 * s - 1, c), 0.0, 1.0)

        lost = [1 - series(e) for e in e_series]
        b_raw = [(1 - series(x)) * m for x, m in zip(x_series, lost, strict=True)]
        # Reciprocity: η² B_in = B_out; the denser side's transmitted share is scaled to it.
        flux = [float(w @ b_raw[0]), eta * eta * float(w @ b_raw[1])]
        dense = 1 if eta > 1 else 0
        kappa = [1.0, 1.0]
        kappa[dense] = flux[1 - dense] / flux[dense] if flux[dense] > 0 else 0.0
        b = [np.minimum(k * raw, m) for k, raw, m in zip(kappa, b_raw, lost, strict=True)]
        a = [m - b_s for m, b_s in zip(lost, b, strict=True)]
        norms = [float(w @ a[0]), eta * eta * float(w @ a[1]), float(w @ b[0])]
        scales = tuple(1 / (math.pi * n) if n > 0 else 0.0 for n in norms)
        for name, value in {
            "_single": single,
            "_e": tuple(tuple(c[:, None]) for c in e_series),
            "_x": tuple(tuple(c[:, None]) for c in x_series),
            "_kappa": tuple(kappa),
            "_scales": scales,  # 1/(π A_out), 1/(π η² A_in), 1/(π B_out)
            "_eta": eta,
        }.items():
            object.__setattr__(self, name, value)

    def _channel_values(self) -> dict[str, Any]:
        """None: the model is grey (α and η are one number each)."""
        return {}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(alpha=0.3),
            cls(alpha=1.0, eta=1.33),
            cls(alpha=0.6, eta=1 / 1.5, mode="importance"),
            cls(alpha=0.8, split="fresnel_average"),
        ]

    def params(self) -> dict[str, Any]:
        return defined_params(self)

    # -- the compensated energy ------------------------------------------------------------
    def E(self, w: Array) -> Array:
        r"""E(μ), the single-scattering flux albedo R + T seen from ``w`` ``(..., 3)`` on its
        side, ``(..., 1)``, clamped to [0, 1]."""
        xp = namespace(w)
        mu = xp.abs(w[..., 2:3])
        e = xp.where(w[..., 2:3] > 0, _clenshaw(self._e[0], mu), _clenshaw(self._e[1], mu))
        return clamp(e, 0.0, 1.0)

    @per_direction
    def shares(self, w: Array) -> tuple[Array, Array]:
        r"""(a, b): the reflected and transmitted flux albedos of the added lobe seen from
        ``w`` ``(..., 3)``, each ``(..., 1)``; a + b = 1 − E(μ) (module docstring). Made once
        per direction of a broadcast ``w`` (the fixed ωo of :meth:`eval` in a quadrature
        ring, a check's samples): three Chebyshev series of degree 32."""
        xp = namespace(w)
        mu = xp.abs(w[..., 2:3])
        outside = w[..., 2:3] > 0
        lost = 1 - self.E(w)
        b = [
            xp.minimum(kappa * (1 - clamp(_clenshaw(x, mu), 0.0, 1.0)) * lost, lost)
            for x, kappa in zip(self._x, self._kappa, strict=True)
        ]
        b = xp.where(outside, b[0], b[1])
        return lost - b, b

    def _index_sqr(self, w: Array) -> Array:
        """n² of the medium ``w`` lies in: 1 outside, η² inside, ``(..., 1)``."""
        xp = namespace(w)
        eta = param(self._eta, w)
        return xp.where(w[..., 2:3] > 0, xp.ones_like(eta), eta * eta)

    def _eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        a_i, b_i = self.shares(wi)
        a_o, b_o = self.shares(wo)
        scale_out, scale_in, scale_t = (param(n, wi) for n in self._scales)
        outside_o = wo[..., 2:3] > 0
        same = (wi[..., 2:3] > 0) == outside_o
        k_r = a_i * a_o * xp.where(outside_o, scale_out, scale_in)
        k_t = b_i * b_o * scale_t
        kernel = xp.where(same, k_r, k_t)
        kernel = kernel * self._index_sqr(wi if self.mode == "importance" else wo)
        grazing = (wi[..., 2:3] == 0) | (wo[..., 2:3] == 0)
        kernel = xp.where(grazing, xp.zeros_like(kernel), kernel)
        return self._single.eval(wi, wo) + kernel

    # -- sampling --------------------------------------------------------------------------
    @per_direction
    def _probabilities(self, wo: Array) -> list[Array]:
        """Choice probabilities of the single lobe, the added reflection and the added
        transmission at ``wo``, each ``(...,)``."""
        a, b = self.shares(wo)
        return normalized_weights([self.E(wo)[..., 0], a[..., 0], b[..., 0]])

    def _pdf(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        p_single, p_r, p_t = self._probabilities(wo)
        side = xp.where(wo[..., 2:3] > 0, xp.ones_like(wo[..., 2:3]), -xp.ones_like(wo[..., 2:3]))
        return (
            p_single * self._single.pdf(wi, wo)
            + p_r * square_to_cosine_hemisphere_pdf(wi * side)  # cosine lobe on wo's side
            + p_t * square_to_cosine_hemisphere_pdf(-wi * side)  # and on the other
        )

    def _sample(self, wo: Array, u: Array) -> Sample:
        return self._mixture_sample(wo, u, one_sided=False)

    def pdf_one_sided(self, wi: Array, wo: Array) -> Array:
        """The density of :meth:`sample_one_sided`: the single lobe's one-sided density and
        the cosine lobe of the added light that reaches the upper hemisphere (reflection
        from outside, transmission from inside), 0 below the surface."""
        xp = namespace(wi, wo)
        p_single, p_cosine = self._probabilities_one_sided(wo)
        value = p_single * self._single.pdf_one_sided(wi, wo)
        value = value + p_cosine * square_to_cosine_hemisphere_pdf(wi)
        return xp.where(wi[..., 2] > 0, value, xp.zeros_like(value))

    def sample_one_sided(self, wo: Array, u: Array) -> Sample:
        """:meth:`sample` restricted to the upper hemisphere (``wi.z > 0``), for a one-sided
        render (:mod:`brdfkit.brdf.one_sided`): the single lobe's
        :meth:`~brdfkit.brdf.RoughDielectric.sample_one_sided` or the cosine lobe of the
        added light on that side, the weight f·|cos θi|/p carrying the rest."""
        return self._mixture_sample(wo, u, one_sided=True)

    @per_direction
    def _probabilities_one_sided(self, wo: Array) -> list[Array]:
        xp = namespace(wo)
        a, b = self.shares(wo)
        added = xp.where(wo[..., 2:3] > 0, a, b)[..., 0]
        return normalized_weights([self.E(wo)[..., 0], added])

    def _mixture_sample(self, wo: Array, u: Array, one_sided: bool) -> Sample:
        """One sample of the mixture of the single lobe and the added cosine lobes (or, with
        ``one_sided``, of those into the upper hemisphere)."""
        if u.shape[-1] < 3:
            raise ParameterError(
                "u must have 3 uniforms per sample for kulla_conty_dielectric (the lobe, the "
                f"normal, reflection or refraction); got shape {tuple(u.shape)}"
            )
        xp = namespace(wo, u)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        wo = xp.broadcast_to(wo, (*batch, 3))
        u = xp.broadcast_to(u, (*batch, u.shape[-1]))[..., :3]
        flip = xp.asarray([1.0, 1.0, -1.0], dtype=wo.dtype)
        down = wo[..., 2:3] < 0
        if one_sided:
            choices = mixture_choices(self._probabilities_one_sided(wo), u)
            single = self._single.sample_one_sided(wo, choices[0][1])
            cosine = square_to_cosine_hemisphere(choices[1][1][..., :2])
            wi = xp.where(choices[1][0][..., None], cosine, single.wi)
            pdf = self.pdf_one_sided(wi, wo)
        else:
            choices = mixture_choices(self._probabilities(wo), u)
            single = self._single.sample(wo, choices[0][1])
            cosine = [square_to_cosine_hemisphere(choices[k][1][..., :2]) for k in (1, 2)]
            reflected = xp.where(down, cosine[0] * flip, cosine[0])  # wo's side
            transmitted = xp.where(down, cosine[1], cosine[1] * flip)  # the other
            wi = xp.where(choices[1][0][..., None], reflected, single.wi)
            wi = xp.where(choices[2][0][..., None], transmitted, wi)
            pdf = self.pdf(wi, wo)
        ok = (pdf > 0) & ~(choices[0][0] & (single.pdf == 0))  # the lobe's failed samples
        safe_pdf = xp.where(ok, pdf, xp.ones_like(pdf))
        weight = self.eval(wi, wo) * (xp.abs(wi[..., 2]) / safe_pdf)[..., None]
        weight = xp.where(ok[..., None], weight, xp.zeros_like(weight))
        pdf = xp.where(ok, pdf, xp.zeros_like(pdf))
        return Sample(wi, weight, pdf, xp.zeros(batch, dtype=xp.bool))

    def _sampling_weight(self, wo: Array) -> Array:
        return interface_sampling_weight(wo)


def added_albedo(model: KullaContyDielectric, wo: np.ndarray, n: int = 128) -> np.ndarray:
    r"""The albedo the compensation adds at ``wo`` ``(3,)``: :math:`\int (f - f_{ss})
    |\cos\theta_i|\, d\omega_i` over the side of ``wo`` and over the other, ``(2,)``, by
    ``n``-node Gauss–Legendre in :math:`\sqrt{\mu_i}` (the added lobes are isotropic in
    :math:`\phi_i`)."""
    x, w = np.polynomial.legendre.leggauss(n)
    s, w = (x + 1) / 2, w / 2
    mu = s * s
    out = []
    for side in (np.sign(wo[2]), -np.sign(wo[2])):
        wi = np.stack([np.sqrt(1 - mu**2), 0 * mu, side * mu], axis=-1)
        added = (model.eval(wi, wo) - model._single.eval(wi, wo))[:, 0]
        out.append(2 * math.pi * np.sum(w * 2 * s * mu * added))  # dμ = 2s ds
    return np.array(out)


__all__ = [
    "COMPENSATED_IOR",
    "ETA_RANGE",
    "SPLITS",
    "SPLIT_TABLE_AXES",
    "SPLIT_TABLE_PATHS",
    "KullaContyDielectric",
    "added_albedo",
    "albedo_series",
    "dielectric_albedo",
    "single_scattering",
    "split_node",
    "split_series",
    "split_table",
]
