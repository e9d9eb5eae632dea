r"""Heitz et al.'s (2016) stochastic random walk on a Smith GGX microsurface (the reference).

A ray enters the microsurface (uncorrelated heights, uniform height distribution, GGX slopes),
and at each step its next intersection height is drawn from Smith's masking
(:math:`G_1(\omega, h) = C_1(h)^{\Lambda(\omega)}`: with probability :math:`G_1` it leaves),
a facet normal is drawn from the normals visible from the ray, and the ray is mirrored about
it, its energy multiplied by the facet's Fresnel reflectance. The mean energy of the escaped
rays is the microsurface's directional albedo with every order of scattering; the first order
alone is the classical GGX conductor with height-correlated Smith masking–shadowing.

:func:`dielectric_random_walk_albedo` is the same walk on a dielectric interface (Heitz et
al. §5): a ray reflects with probability F or refracts through the microsurface, which it
then sees mirrored from below.

This is a NumPy Monte Carlo reference, not a model: the walk is stochastic per ray.
:class:`KullaConty`'s Fresnel table is generated from it (``benchmarks/kulla_conty_table.py``),
and :class:`KullaContyDielectric`'s split of R and T
(``benchmarks/kulla_conty_dielectric_table.py``); both models are checked against it with
independent seeds and directions. Only the paths still inside are carried from one order to
the next, so the cost is the paths' total length.

References
----------
.. [1] E. Heitz, J. Hanika, E. d'Eon, C. Dachsbacher, "Multiple-scattering microfacet BSDFs
       with the Smith model", ACM TOG 35(4), 2016, and its supplemental code.
.. [2] J. Dupuy, A. Benyoub, "Sampling visible GGX normals with spherical caps", Computer
       Graphics Forum 42(8), 2023.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from brdfkit.brdf.microfacet import GGX, FresnelTerm
from brdfkit.fresnel import fresnel as fresnel_dielectric_term


@dataclass(frozen=True)
class WalkResult:
    """The directional albedo of a random walk, per channel ``(C,)``.

    Attributes
    ----------
    albedo : mean escaped energy (every scattering order).
    stderr : its Monte Carlo standard error.
    single : the part that escaped after exactly one reflection (single scattering).
    lost : the energy still inside after the last order allowed (a bias, ≤ this).
    escaped_later : the fraction of paths that escaped after two or more reflections, a
        scalar: the multiple-scattering albedo with F = 1 *of the same paths* (the
        denominator of a ratio estimator of the Fresnel attenuation of multiple scattering).
    """

    albedo: np.ndarray
    stderr: np.ndarray
    single: np.ndarray
    lost: np.ndarray
    escaped_later: float


def sample_visible_any(alpha: float, w: np.ndarray, u: np.ndarray) -> np.ndarray:
    r"""GGX normals visible from ``w`` *above or below the horizon*, density
    :math:`\propto \langle\omega\cdot\omega_m\rangle D(\omega_m)` over :math:`m_z > 0`.

    Dupuy & Benyoub's (2023) spherical caps: in the α = 1 configuration the normalised sum of
    the (stretched) direction and a point uniform on the cap :math:`z > -\omega_z` has that
    density for any ω. :meth:`~brdfkit.brdf.microfacet.GGX.sample_visible` (Heitz 2018)
    covers ω above the horizon only, and a ray inside the microsurface travels upwards too.
    """
    ws = np.stack([alpha * w[..., 0], alpha * w[..., 1], w[..., 2]], axis=-1)
    ws /= np.linalg.norm(ws, axis=-1, keepdims=True)
    phi = 2 * math.pi * u[..., 0]
    z = (1 - u[..., 1]) * (1 + ws[..., 2]) - ws[..., 2]
    sin_theta = np.sqrt(np.clip(1 - z * z, 0, 1))
    h = np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), z], axis=-1) + ws
    m = np.stack([alpha * h[..., 0], alpha * h[..., 1], np.maximum(h[..., 2], 0)], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def random_walk_albedo(
    alpha: float,
    wo: np.ndarray,
    fresnel: FresnelTerm | None = None,
    paths: int = 1 << 18,
    seed: int = 0,
    max_order: int = 100,
) -> WalkResult:
    """The directional albedo of the GGX conductor microsurface seen from ``wo`` (unit,
    ``wo.z > 0``), by ``paths`` random walks of at most ``max_order`` reflections (Heitz et
    al. 2016; see the module docstring). ``fresnel`` defaults to F = 1.
    """
    rng = np.random.default_rng(seed)
    fresnel = fresnel or FresnelTerm("none")
    ggx = GGX(alpha)
    # Only the paths still inside are carried from one order to the next.
    wr = np.broadcast_to(-np.asarray(wo, dtype=np.float64), (paths, 3)).copy()
    c1 = np.ones(paths)  # C1(h) of the current height: the walk starts above the surface
    energy = np.ones((paths, fresnel.channels))
    total = np.zeros(fresnel.channels)
    total_sq = np.zeros(fresnel.channels)
    single = np.zeros(fresnel.channels)
    later = 0
    for order in range(max_order + 1):
        up = wr[:, 2] > 0
        lam = ggx.smith_lambda(wr)[:, 0]  # even in w.z
        lam = np.where(up, lam, -1 - lam)  # Λ(−ω) = −1 − Λ(ω) (Heitz 2016)
        u = rng.random(wr.shape[0])
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            g1 = np.where(up, c1**lam, 0.0)
        leaves = up & (u > 1 - g1)
        out = energy[leaves]
        total += out.sum(axis=0)
        total_sq += (out * out).sum(axis=0)
        if order == 1:
            single = out.sum(axis=0) / paths
        elif order > 1:
            later += int(leaves.sum())
        stay = ~leaves
        wr, c1, u, lam, energy = wr[stay], c1[stay], u[stay], lam[stay], energy[stay]
        if order == max_order or wr.shape[0] == 0:
            break
        with np.errstate(divide="ignore", over="ignore"):
            c1 = np.clip(c1 / (1 - u) ** (1 / lam), 0.0, 1.0)
        wm = sample_visible_any(alpha, -wr, rng.random((wr.shape[0], 2)))
        cos_m = np.sum(-wr * wm, axis=-1, keepdims=True)
        energy = energy * fresnel(cos_m)
        wr = wr - 2 * np.sum(wr * wm, axis=-1, keepdims=True) * wm
    lost = energy.sum(axis=0) / paths
    albedo = total / paths
    stderr = np.sqrt(np.maximum(total_sq / paths - albedo**2, 0) / paths)
    return WalkResult(albedo, stderr, single, lost, later / paths)


@dataclass(frozen=True)
class DielectricWalkResult:
    """The directional albedo of a dielectric random walk, split by the side it leaves on.

    Attributes
    ----------
    reflected, transmitted : fraction of the paths that leave on the side of ``wo``, and on
        the other side (every scattering order).
    reflected_single, transmitted_single : the fractions that leave after exactly one event.
    stderr : the Monte Carlo standard error of ``reflected`` (and of ``transmitted``: the
        paths are Bernoulli draws, ``reflected + transmitted + lost = 1``).
    lost : the fraction still inside after the last order allowed (a bias, ≤ this).
    """

    reflected: float
    transmitted: float
    reflected_single: float
    transmitted_single: float
    stderr: float
    lost: float


def _lambda_signed(ggx: GGX, w: np.ndarray) -> np.ndarray:
    """Smith's Λ of a ray direction, upwards or downwards: Λ(−ω) = −1 − Λ(ω) (Heitz 2016)."""
    lam = ggx.smith_lambda(w)[:, 0]  # even in w.z
    return np.where(w[:, 2] > 0, lam, -1 - lam)


def dielectric_random_walk_albedo(
    alpha: float,
    eta: float,
    wo: np.ndarray,
    paths: int = 1 << 16,
    seed: int = 0,
    max_order: int = 100,
) -> DielectricWalkResult:
    r"""The directional albedo, reflected and transmitted, of the GGX dielectric microsurface
    of relative index ``eta`` = n_inside / n_outside seen from ``wo`` (unit; ``wo.z > 0``
    outside, ``< 0`` inside), by ``paths`` random walks of at most ``max_order`` events
    (Heitz et al. 2016 §5 and their supplemental ``MicrosurfaceDielectric``).

    A ray inside the dielectric sees the microsurface mirrored (heights and directions
    negated), so the walk below the interface is the walk above it with
    :math:`C_1 	o 1 - C_1` (uniform heights) and ω → −ω. At each event a normal is drawn
    from those visible to the ray on its side; the ray reflects with probability
    F(ωi·ωm) (:func:`brdfkit.fresnel.fresnel`, 1 under total internal reflection) and
    otherwise refracts to the other side. Energy is never weighted: without absorption
    every path carries 1, and the albedo is the fraction that leaves on each side, i.e.
    the flux (importance-mode) albedo.
    """
    rng = np.random.default_rng(seed)
    ggx = GGX(alpha)
    wo = np.asarray(wo, dtype=np.float64)
    start_outside = bool(wo[2] > 0)
    wr = np.broadcast_to(-wo, (paths, 3)).copy()
    outside = np.full(paths, start_outside)
    c1 = np.full(paths, 1.0 if start_outside else 0.0)  # C1 of the height, outside's frame
    left_outside = left_inside = 0
    single = [0, 0]
    for order in range(max_order + 1):
        sign = np.where(outside, 1.0, -1.0)[:, None]
        w, c = wr * sign, np.where(outside, c1, 1 - c1)  # the ray in its own side's frame
        up = w[:, 2] > 0
        lam = _lambda_signed(ggx, w)
        u = rng.random(wr.shape[0])
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            g1 = np.where(up, c**lam, 0.0)
        leaves = up & (u > 1 - g1)
        n_out, n_in = int(np.sum(leaves & outside)), int(np.sum(leaves & ~outside))
        left_outside, left_inside = left_outside + n_out, left_inside + n_in
        if order == 1:
            single = [n_out, n_in]
        stay = ~leaves
        wr, w, c, u, lam, outside = wr[stay], w[stay], c[stay], u[stay], lam[stay], outside[stay]
        if order == max_order or wr.shape[0] == 0:
            break
        with np.errstate(divide="ignore", over="ignore"):
            c = np.clip(c / (1 - u) ** (1 / lam), 0.0, 1.0)
        c1 = np.where(outside, c, 1 - c)
        sign = np.where(outside, 1.0, -1.0)[:, None]
        wm = sign * sample_visible_any(alpha, -w, rng.random((wr.shape[0], 2)))
        wi = -wr  # towards where the ray came from
        cos_i = np.clip(np.sum(wi * wm, axis=-1, keepdims=True), 0.0, 1.0)
        eta_side = np.where(outside, eta, 1 / eta)[:, None]  # n_other / n_this side
        f, cos_t, _, eta_ti = fresnel_dielectric_term(cos_i, eta_side)
        reflect = rng.random((wr.shape[0], 1)) < f
        reflected = 2 * cos_i * wm - wi
        refracted = wm * (cos_i * eta_ti + cos_t) - wi * eta_ti
        wr = np.where(reflect, reflected, refracted)
        wr /= np.linalg.norm(wr, axis=-1, keepdims=True)
        outside = np.where(reflect[:, 0], outside, ~outside)
    same, other = (left_outside, left_inside) if start_outside else (left_inside, left_outside)
    s_same, s_other = single if start_outside else single[::-1]
    reflected = same / paths
    return DielectricWalkResult(
        reflected=reflected,
        transmitted=other / paths,
        reflected_single=s_same / paths,
        transmitted_single=s_other / paths,
        stderr=math.sqrt(max(reflected * (1 - reflected), 0.0) / paths),
        lost=wr.shape[0] / paths,
    )


__all__ = [
    "DielectricWalkResult",
    "WalkResult",
    "dielectric_random_walk_albedo",
    "random_walk_albedo",
    "sample_visible_any",
]
