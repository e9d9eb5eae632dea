r"""Kulla & Conty's (2017) energy compensation for rough GGX conductors (multiple scattering)."""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from importlib.resources import files
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, clamp, namespace, safe_sqrt, to_numpy
from brdfkit.brdf.base import BRDF, normalized_weights, per_direction, register
from brdfkit.brdf.microfacet import EXTINCTION, GGX, IOR, FresnelTerm
from brdfkit.brdf.microfacet_reflection import defined_params
from brdfkit.brdf.phong import Component, MixtureSampled, channel_mean, cosine_component
from brdfkit.brdf.random_walk import random_walk_albedo
from brdfkit.brdf.rough_conductor import RoughConductor
from brdfkit.errors import ParameterError
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.params import Domain, param

COMPENSATED_ROUGHNESS = Domain(0.01, 1.0, hint="GGX roughness α of the tabulated range")
"""The roughness α of :class:`KullaConty`: [0.01, 1], where E(μ) is tabulated to ≤ 2·10⁻⁴
(below 0.01 single scattering loses < 0.1 % and E's grazing step outruns the series)."""

DEGREE = 32
"""Degree of the Chebyshev series of E(μ) in √μ (33 quadrature directions per α)."""

QUADRATURE_NODES = (96, 64)
"""Gauss–Legendre nodes in the radius (r = sin t) and trapezoid nodes in the azimuth of the
visible-normal disk per direction in :func:`ggx_albedo` (E within ~10⁻⁴ of 512 × 512)."""

FRESNEL_TABLE_AXES: dict[str, tuple[int, float, float]] = {
    "alpha": (10, 0.01, 1.0),
    "s": (14, 0.0, 1.0),
    "r": (10, 0.0, 1.0),
    "h": (6, 0.0, 1.0),
}
"""Axes of the shipped Fresnel table (:func:`fresnel_ratio_table`): (nodes, low, high) of
Chebyshev points of the first kind in the roughness α, s = √μo, and Gulbrandsen's
reflectivity r and log-index position h (:func:`table_coordinates_from_conductor`)."""


def chebyshev_nodes(n: int, low: float, high: float) -> np.ndarray:
    """The ``n`` Chebyshev points of the first kind on [low, high], increasing."""
    x = np.cos(math.pi * (np.arange(n)[::-1] + 0.5) / n)
    return low + (high - low) * (x + 1) / 2


def chebyshev_weights(value: Any, n: int, low: float, high: float) -> np.ndarray:
    """Weights ``(..., n)`` that map the values at :func:`chebyshev_nodes` to the value of
    their interpolating polynomial (degree n − 1) at ``value``, any shape."""
    x = 2 * (np.asarray(value, dtype=np.float64) - low) / (high - low) - 1
    nodes = 2 * (chebyshev_nodes(n, low, high) - low) / (high - low) - 1
    degree = np.arange(n)
    basis_at_nodes = np.cos(degree[:, None] * np.arccos(nodes)[None, :])  # T_k(x_j)
    scale = np.where(degree == 0, 1.0, 2.0) / n
    basis = np.polynomial.chebyshev.chebvander(x, n - 1).reshape(*x.shape, n)  # T_k(x)
    return (basis * scale) @ basis_at_nodes


def _index_bounds(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gulbrandsen's (2014) range of η for the reflectivity r: (1 − r)/(1 + r) (his edge tint
    g = 1) to (1 + √r)/(1 − √r) (k = 0)."""
    return (1 - r) / (1 + r), (1 + np.sqrt(r)) / (1 - np.sqrt(r))


def conductor_from_table_coordinates(r: Any, h: Any) -> tuple[np.ndarray, np.ndarray]:
    r"""The conductor (η, k) at the Fresnel-table coordinates (r, h): reflectivity r = F(1) ∈
    [0, 1) and h ∈ [0, 1] the position of ln η between Gulbrandsen's (2014) bounds
    :math:`\eta_{min} = (1-r)/(1+r)` (h = 0) and :math:`\eta_{max} = (1+\sqrt r)/(1-\sqrt r)`
    (h = 1, k = 0: a dielectric), :math:`\eta = \eta_{min}(\eta_{max}/\eta_{min})^h`,
    :math:`k = \sqrt{(r(\eta+1)^2 - (\eta-1)^2)/(1-r)}`. (Gulbrandsen's own edge tint,
    linear in η, makes the multiple-scattering albedo steep near g = 1, where metals are;
    ln η keeps it smooth.)"""
    r, h = np.asarray(r, dtype=np.float64), np.asarray(h, dtype=np.float64)
    eta_min, eta_max = _index_bounds(r)
    eta = eta_min * (eta_max / eta_min) ** h
    k = np.sqrt(np.maximum(r * (eta + 1) ** 2 - (eta - 1) ** 2, 0) / (1 - r))
    return eta, k


def table_coordinates_from_conductor(eta: Any, k: Any) -> tuple[np.ndarray, np.ndarray]:
    """The inverse of :func:`conductor_from_table_coordinates`: (r, h) of a conductor (η, k),
    h clamped to [0, 1] (η below Gulbrandsen's bound, which no metal of
    :data:`brdfkit.fresnel.CONDUCTORS` has, reads the table at h = 0; r = 0 at h = 1)."""
    eta, k = np.asarray(eta, dtype=np.float64), np.asarray(k, dtype=np.float64)
    r = ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2)
    eta_min, eta_max = _index_bounds(np.minimum(r, 1 - 1e-12))
    span = np.log(eta_max / np.maximum(eta_min, 1e-300))
    h = np.where(span > 0, np.log(eta / eta_min) / np.where(span > 0, span, 1.0), 1.0)
    return r, np.clip(h, 0.0, 1.0)


def visible_normal_quadrature(
    nodes: tuple[int, int] = QUADRATURE_NODES, *, mirror: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    r"""Nodes ``(n, 2)`` and weights ``(n,)`` on the unit square of Heitz's (2018) visible-normal
    map (:meth:`~brdfkit.brdf.microfacet.GGX.sample_visible`): its radius as r = sin t (which
    resolves the steep facets at the disk's rim), Gauss–Legendre in t, the trapezoid rule in
    the (periodic) azimuth; ``nodes`` = (radial, azimuthal). A sum over them of g(ωm(u)) is
    the mean of g over the normals visible from ω.

    ``mirror``: only the azimuths with cos φ > 0, at twice the weight, for a g even in the
    disk's first coordinate r cos φ (the azimuths pair up as φ, π − φ: ``nodes[1]`` must be
    a multiple of 4). Seen from ω in the xz-plane, an isotropic distribution's map turns
    that coordinate into the normal's y, so that a g even in y (a view in the xz-plane, an
    isotropic lobe) sums to the same value, to rounding, from half the nodes."""
    n_r, n_phi = nodes
    if mirror and n_phi % 4:
        raise ValueError(f"mirror needs a multiple of 4 azimuthal nodes; got {n_phi}")
    x, w = np.polynomial.legendre.leggauss(n_r)
    t = 0.25 * math.pi * (x + 1)
    r = np.sin(t)
    w_r = 0.25 * math.pi * w * 2 * r * np.cos(t)  # du0 = 2 r dr, u0 = r²
    u_phi = (np.arange(n_phi) + 0.5) / n_phi
    w_phi = np.full(n_phi, 1 / n_phi)
    if mirror:  # φ = 2π u in (−π/2, π/2): the first and the last quarter of the azimuths
        quarter = n_phi // 4
        u_phi = np.concatenate([u_phi[:quarter], u_phi[-quarter:]])
        w_phi = np.full(2 * quarter, 2 / n_phi)
    u0, u1 = np.meshgrid(r * r, u_phi, indexing="ij")
    u = np.stack([u0.ravel(), u1.ravel()], axis=-1)
    return u, np.outer(w_r, w_phi).ravel()


def ggx_albedo(
    alpha: float,
    mu: Any,
    fresnel: FresnelTerm | None = None,
    nodes: tuple[int, int] = QUADRATURE_NODES,
) -> np.ndarray:
    r"""Directional albedo of the single-scattering GGX conductor (height-correlated Smith),
    by deterministic quadrature: :math:`E_F(\mu_o) = \int F\,G_2/G_1(\omega_o)\,
    D_{\omega_o}(\omega_m)\,d\omega_m` over the visible normals.

    The integral runs over the unit square of Heitz's (2018) visible-normal map
    (:func:`visible_normal_quadrature`).

    Parameters
    ----------
    alpha : isotropic GGX roughness.
    mu : cosines of the view directions, any shape, in (0, 1].
    fresnel : the Fresnel factor (default: F = 1, the E(μ) of Kulla & Conty).
    nodes : (radial, azimuthal) quadrature nodes.

    Returns
    -------
    numpy.ndarray
        ``mu.shape + (C,)``, C the Fresnel term's channels (1 for F = 1).
    """
    mu = np.asarray(mu, dtype=np.float64)
    u, weights = visible_normal_quadrature(nodes, mirror=True)  # ωo in the xz-plane
    flat = mu.reshape(-1)
    wo = spherical_to_cartesian(np.arccos(np.clip(flat, 0, 1)), np.zeros_like(flat))[:, None, :]
    wo = np.broadcast_to(wo, (flat.size, u.shape[0], 3))
    ggx = GGX(alpha)
    wm = ggx.sample_visible(wo, np.broadcast_to(u, (flat.size, *u.shape)))
    wo_m = np.sum(wo * wm, axis=-1, keepdims=True)
    wi = 2 * wo_m * wm - wo
    lambda_i, lambda_o = ggx.smith_lambda(wi), ggx.smith_lambda(wo)
    ratio = np.where(wi[..., 2:3] > 0, (1 + lambda_o) / (1 + lambda_i + lambda_o), 0.0)
    if fresnel is not None:
        ratio = ratio * fresnel(wo_m)
    albedo = np.einsum("pnc,n->pc", ratio, weights)
    return albedo.reshape(*mu.shape, albedo.shape[-1])


@functools.lru_cache(maxsize=128)
def albedo_table(alpha: float) -> tuple[np.ndarray, float]:
    r"""Kulla & Conty's tables for GGX roughness ``alpha``, computed once and kept in memory:
    the Chebyshev coefficients of E(μ) (F = 1) as a series in :math:`x = 2\sqrt\mu - 1`, and
    :math:`E_{avg} = 2\int_0^1 E(\mu)\,\mu\,d\mu`.

    E is sampled by :func:`ggx_albedo` at the DEGREE + 1 Chebyshev points; the
    series in √μ follows E's steep rise to 1 at grazing view, where a grid in μ would not.
    """
    coefficients = np.polynomial.chebyshev.chebinterpolate(
        lambda x: ggx_albedo(alpha, ((x + 1) / 2) ** 2)[..., 0], DEGREE
    )
    s, w = np.polynomial.legendre.leggauss(64)
    s, w = (s + 1) / 2, w / 2
    e = np.polynomial.chebyshev.chebval(2 * s - 1, coefficients)
    return coefficients, float(4 * np.sum(w * e * s**3))  # μ = s², 2μ dμ = 4 s³ ds


FRESNEL_TABLE_PATHS = 1 << 17
"""Random-walk paths per (α, μo) node of the shipped Fresnel table."""


def fresnel_ratio_node(
    i: int, j: int, paths: int = FRESNEL_TABLE_PATHS
) -> tuple[np.ndarray, float]:
    r"""One (α, s) node ``(i, j)`` of :func:`fresnel_ratio_table`, by the random walk
    (seed ``1000 i + j``): the ratio estimator of R at every (r, h) node, ``(n_r, n_h)``, and
    the fraction of paths that escaped after ≥ 2 reflections (its denominator)."""
    nodes = {name: chebyshev_nodes(*axis) for name, axis in FRESNEL_TABLE_AXES.items()}
    r, h = np.meshgrid(nodes["r"], nodes["h"], indexing="ij")
    eta, k = conductor_from_table_coordinates(r.ravel(), h.ravel())
    fresnel = FresnelTerm("conductor", eta, k)  # nodes near r = 1 exceed the users' η domain
    s = nodes["s"][j]
    wo = spherical_to_cartesian(np.arccos(s * s), np.array(0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # 0 ** negative in the masking
        walk = random_walk_albedo(
            float(nodes["alpha"][i]), wo, fresnel=fresnel, paths=paths, seed=1000 * i + j
        )
    ratio = (walk.albedo - walk.single) / max(walk.escaped_later, 1 / paths)
    return ratio.reshape(r.shape), walk.escaped_later


@functools.lru_cache(maxsize=1)
def fresnel_ratio_table() -> np.ndarray:
    r"""The shipped table ``(alpha, s, r, h)`` of :math:`R = E_{ms,F}(\mu_o) / (1 - E(\mu_o))`,
    the fraction of the F = 1 multiple-scattering albedo a conductor's Fresnel term lets out,
    at the Chebyshev nodes of :data:`FRESNEL_TABLE_AXES`, estimated by Heitz et al.'s (2016)
    random walk (2¹⁷ paths per (α, μo), ratio estimator on shared paths); regenerated by
    ``benchmarks/kulla_conty_table.py``."""
    with (files("brdfkit.data") / "kulla_conty_fresnel.npz").open("rb") as handle:
        table = np.load(handle)["ratio"].astype(np.float64)
    expected = tuple(n for n, _, _ in FRESNEL_TABLE_AXES.values())
    if table.shape != expected:  # pragma: no cover - a stale table
        raise RuntimeError(f"kulla_conty_fresnel.npz has shape {table.shape}, not {expected}")
    return table


def fresnel_ratio_series(alpha: float, eta: float, k: float) -> np.ndarray:
    r"""Chebyshev coefficients, in :math:`x = 2\sqrt{\mu_o} - 1`, of the Fresnel ratio R(μo)
    of one channel (roughness ``alpha``, conductor ``eta`` + i ``k``): the table of
    :func:`fresnel_ratio_table` interpolated in α, r and h (tensor Chebyshev), then in s."""
    r, h = table_coordinates_from_conductor(eta, k)
    weights = {
        "alpha": chebyshev_weights(alpha, *FRESNEL_TABLE_AXES["alpha"]),
        "r": chebyshev_weights(r, *FRESNEL_TABLE_AXES["r"]),
        "h": chebyshev_weights(h, *FRESNEL_TABLE_AXES["h"]),
    }
    at_s = np.einsum(
        "asrh,a,r,h->s", fresnel_ratio_table(), weights["alpha"], weights["r"], weights["h"]
    )
    n_s, _, _ = FRESNEL_TABLE_AXES["s"]
    x_nodes = 2 * chebyshev_nodes(n_s, 0.0, 1.0) - 1
    return np.polynomial.chebyshev.chebfit(x_nodes, np.clip(at_s, 0.0, 1.0), n_s - 1)


@register("kulla_conty")
@dataclass(frozen=True, eq=False)
class KullaConty(MixtureSampled):
    r"""A rough GGX conductor with Kulla & Conty's (2017) multiple-scattering compensation,
    its Fresnel attenuation tabulated from Heitz et al.'s (2016) random walk.

    .. math::
        f_r = f_{ss} + \frac{E_{ms}(\mu_i)\,E_{ms}(\mu_o)}{\pi\,E_{ms,avg}},\qquad
        E_{ms}(\mu) = R(\mu)\,(1 - E(\mu)),\qquad E_{ms,avg} = 2\int_0^1 E_{ms}\,\mu\,d\mu,

    with :math:`f_{ss}` the single-scattering :class:`~brdfkit.brdf.RoughConductor` (GGX,
    height-correlated Smith) and E(μ) its directional albedo with F = 1. The added lobe is
    separable and symmetric, and its directional albedo is exactly :math:`E_{ms}(\mu_o)`, the
    microsurface's multiple-scattering albedo. With F = 1, R = 1 and the lobe is Kulla &
    Conty's :math:`(1 - E(\mu_i))(1 - E(\mu_o))/(\pi(1 - E_{avg}))` (Kelemen &
    Szirmay-Kalos's coupling), which restores the energy 1 − E(μo) single scattering loses.

    For a coloured conductor, Kulla & Conty scale that lobe by
    :math:`F_{avg}^2 E_{avg}/(1 - F_{avg}(1 - E_{avg}))`, as if every later bounce met the
    hemispherical average :math:`F_{avg}`; but the bounces after the first meet facets
    obliquely, where F is larger, and gold and copper at α = 1 then fall up to 7 % and 8 %
    short of the random walk (blue, θo = 60°; ``benchmarks/kulla_conty_accuracy.py``).
    Here instead R(μo) = E_ms,F / (1 − E) is the fraction of the
    multiple-scattering energy the actual Fresnel term lets out, per channel, tabulated by
    the random walk over (α, √μo, r, h) (:func:`fresnel_ratio_table`; r = F(1) and h, ln η
    between Gulbrandsen's bounds, re-parametrise the conductor's η + ik) and
    interpolated as a tensor Chebyshev series. E is computed by brdfkit (:func:`albedo_table`:
    quadrature, a Chebyshev series in √μ per α, cached in memory); R's table (32 KB) is
    generated by ``benchmarks/kulla_conty_table.py``.

    **Reciprocal**: yes (the added lobe is symmetric in μi, μo). **Energy-conserving**: yes
    (R ≤ 1 and the single-scattering albedo with Fresnel is ≤ E, so the albedo is ≤ 1); with
    F = 1 the albedo is 1 to the table's accuracy (≤ 0.5 % for α ∈ [0.05, 1], θo < 85°,
    tested; measured ≤ 1.9·10⁻⁴). Its directional albedo agrees with the random walk on the
    same microsurface (:func:`brdfkit.brdf.random_walk.random_walk_albedo`, independent seeds)
    within 2 % per channel for Au, Cu, Al and F = 1 over α ∈ [0.05, 1], θo < 85° (tested;
    measured worst 0.37 %). What is matched is the directional albedo of the multiply
    scattered light; its angular distribution is the separable lobe's, not compared with
    the walk's.

    Sampled by a mixture of the single-scattering lobe's visible normals and the
    cosine-weighted hemisphere, chosen in proportion to their albedo estimates at ``wo``.

    Parameters
    ----------
    alpha : isotropic GGX roughness in [0.01, 1], scalar or per channel (not spatially
        varying: E is tabulated per value).
    material, eta, k : the conductor, as :class:`~brdfkit.brdf.RoughConductor`
        (``material="none"``, the default, is F = 1).

    References
    ----------
    .. [1] C. Kulla, A. Conty, "Revisiting physically based shading at Imageworks", SIGGRAPH
           2017 course *Physically Based Shading in Theory and Practice*.
    .. [2] C. Kelemen, L. Szirmay-Kalos, "A microfacet based coupled specular-matte BRDF model
           with importance sampling", Eurographics 2001 (the (1 − E)(1 − E) lobe).
    .. [3] E. Heitz, J. Hanika, E. d'Eon, C. Dachsbacher, "Multiple-scattering microfacet
           BSDFs with the Smith model", ACM TOG 35(4), 2016.
    .. [4] O. Gulbrandsen, "Artist friendly metallic Fresnel", Journal of Computer Graphics
           Techniques 3(4), 2014 (the bounds of η given r behind the table's (r, h)).

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import KullaConty
    >>> f = KullaConty(alpha=1.0)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.3262])
    >>> np.round(f.albedo(wo), 2)
    array([1.])
    """

    alpha: Any = 0.5
    material: str | None = "none"
    eta: Any = None
    k: Any = None
    domains: ClassVar[dict[str, Domain]] = {
        "alpha": COMPENSATED_ROUGHNESS,
        "eta": IOR,
        "k": EXTINCTION,
    }

    def __post_init__(self) -> None:
        super().__post_init__()
        alphas = np.asarray(to_numpy(self.alpha), dtype=np.float64)
        if alphas.ndim > 1:
            raise ParameterError(
                f"alpha must be a scalar or per channel (C,) for kulla_conty (E is tabulated "
                f"per value); got shape {alphas.shape}"
            )
        single = RoughConductor(alpha=self.alpha, material=self.material, eta=self.eta, k=self.k)
        fresnel = single.fresnel_term
        channels = single.channels
        alphas = np.atleast_1d(alphas)  # E per distinct α channel: (1,) for a scalar α
        e_series = np.stack([albedo_table(float(a))[0] for a in alphas], axis=-1)
        alphas = np.broadcast_to(alphas, (channels,))
        if fresnel.kind == "none":
            r_series = np.ones((1, channels))  # R = 1
        else:
            etas = np.broadcast_to(
                np.asarray(to_numpy(fresnel.eta), dtype=np.float64), alphas.shape
            )
            ks = np.broadcast_to(np.asarray(to_numpy(fresnel.k), dtype=np.float64), alphas.shape)
            r_series = np.stack(
                [fresnel_ratio_series(*values) for values in zip(alphas, etas, ks, strict=True)],
                axis=-1,
            )
        object.__setattr__(self, "_single", single)
        object.__setattr__(self, "_coefficients", tuple(e_series))
        object.__setattr__(self, "_ratio_coefficients", tuple(r_series))
        s, w = np.polynomial.legendre.leggauss(64)
        s, w = (s + 1) / 2, w / 2
        e_ms = self.E_ms(s[:, None] ** 2)
        e_ms_avg = np.sum((4 * w * s**3)[:, None] * e_ms, axis=0)  # μ = s², 2μ dμ = 4 s³ ds
        positive = e_ms_avg > 0  # F ≡ 0 (η = 1, k = 0) leaves nothing to add
        scale = np.where(positive, 1 / (math.pi * np.where(positive, e_ms_avg, 1.0)), 0.0)
        object.__setattr__(self, "_ms_scale", scale)
        object.__setattr__(self, "channels", channels)

    def _channel_values(self) -> dict[str, Any]:
        """None here: the channels are the single-scattering lobe's (roughness and Fresnel)."""
        return {}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(alpha=0.1),
            cls(alpha=0.5, material="Au"),
            cls(alpha=1.0),
            cls(alpha=[0.3, 0.5, 0.8], material="Cu"),
        ]

    def E(self, mu: Array) -> Array:
        r"""E(μ), the single-scattering albedo with F = 1, from the Chebyshev series (Clenshaw's
        recurrence), clamped to [0, 1]; ``mu`` ``(..., 1)`` → ``(..., C)``."""
        return clamp(_clenshaw(self._coefficients, mu), 0.0, 1.0)

    def E_ms(self, mu: Array) -> Array:
        r""":math:`E_{ms}(\mu) = R(\mu)(1 - E(\mu))`, the multiple-scattering albedo with the
        model's Fresnel term (R from :func:`fresnel_ratio_series`, clamped to [0, 1]);
        ``mu`` ``(..., 1)`` → ``(..., C)``."""
        ratio = clamp(_clenshaw(self._ratio_coefficients, mu), 0.0, 1.0)
        return ratio * (1 - self.E(mu))

    @per_direction
    def _E_ms_of(self, w: Array) -> Array:
        """:meth:`E_ms` at the cosine of ``w`` ``(..., 3)``; made once per direction of a
        broadcast ``w`` (the fixed ωo of :meth:`eval` in a quadrature ring, a check's samples)."""
        return self.E_ms(w[..., 2:3])

    def _eval(self, wi: Array, wo: Array) -> Array:
        single = self._single.eval(wi, wo)
        multiple = self._E_ms_of(wi) * self._E_ms_of(wo) * param(self._ms_scale, wi)
        return single + multiple

    @per_direction
    def _weights(self, wo: Array) -> tuple[Array, Array]:
        """Albedo estimates of the single- and multiple-scattering lobes at ``wo``, ``(...,)``."""
        xp = namespace(wo)
        mu_o = xp.abs(wo[..., 2:3])
        single = channel_mean(self.E(mu_o)) * self._single.sampling_weight(wo)
        multiple = channel_mean(self.E_ms(mu_o))
        multiple = xp.where(wo[..., 2] > 0, multiple, xp.zeros_like(multiple))
        return single, multiple

    def components(self, wo: Array) -> list[Component]:
        p_single, p_multiple = normalized_weights(list(self._weights(wo)))
        return [
            (
                p_single,
                lambda wi: self._single.pdf(wi, wo),
                lambda u: self._single.sample(wo, u).wi,
            ),
            cosine_component(p_multiple),
        ]

    def _sampling_weight(self, wo: Array) -> Array:
        single, multiple = self._weights(wo)
        return single + multiple

    def params(self) -> dict[str, Any]:
        return defined_params(self)


def _clenshaw(coefficients: tuple[np.ndarray, ...], mu: Array) -> Array:
    r"""A per-channel Chebyshev series in :math:`x = 2\sqrt\mu - 1` at ``mu`` ``(..., 1)``
    (Clenshaw's recurrence), ``(..., C)``. Each channel runs on ``(..., 1)`` arrays with
    scalar coefficients, then the channels are joined, so that the loops run over the batch
    rather than over a short trailing axis. On NumPy arrays the recurrence runs in place
    (:func:`_clenshaw_numpy`, the same operations in the same order)."""
    xp = namespace(mu)
    x = 2 * safe_sqrt(clamp(mu, 0.0, 1.0)) - 1
    if type(x) is np.ndarray:
        return _clenshaw_numpy(coefficients, x)
    channels = []
    for c in range(coefficients[0].shape[-1]):
        b1 = b2 = 0 * x
        for a in coefficients[:0:-1]:
            b1, b2 = float(a[c]) + 2 * x * b1 - b2, b1
        channels.append(float(coefficients[0][c]) + x * b1 - b2)
    return channels[0] if len(channels) == 1 else xp.concat(channels, axis=-1)


def _clenshaw_numpy(coefficients: tuple[np.ndarray, ...], x: np.ndarray) -> np.ndarray:
    r""":func:`_clenshaw`'s recurrence on a NumPy ``x``, bit for bit: each step
    :math:`b_1 \leftarrow (a + (2x)\,b_1) - b_2` (a sum of two terms is the same float in
    either order), with 2x made once and the step written into the buffer :math:`b_2` frees
    (three buffers, no temporaries)."""
    two_x = 2 * x
    channels = []
    for c in range(coefficients[0].shape[-1]):
        b1, b2 = 0 * x, 0 * x
        spare = np.empty_like(x)
        for a in coefficients[:0:-1]:
            np.multiply(two_x, b1, out=spare)
            spare += float(a[c])
            spare -= b2
            b1, b2, spare = spare, b1, b2
        np.multiply(x, b1, out=spare)
        spare += float(coefficients[0][c])
        spare -= b2
        channels.append(spare)
    return channels[0] if len(channels) == 1 else np.concatenate(channels, axis=-1)


__all__ = [
    "COMPENSATED_ROUGHNESS",
    "DEGREE",
    "FRESNEL_TABLE_AXES",
    "FRESNEL_TABLE_PATHS",
    "QUADRATURE_NODES",
    "KullaConty",
    "albedo_table",
    "chebyshev_nodes",
    "chebyshev_weights",
    "conductor_from_table_coordinates",
    "fresnel_ratio_node",
    "fresnel_ratio_series",
    "fresnel_ratio_table",
    "ggx_albedo",
    "table_coordinates_from_conductor",
    "visible_normal_quadrature",
]
