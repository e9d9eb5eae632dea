r"""The reflection equation, by quadrature and by Monte Carlo.

.. math:: L_o(\omega_o) = \int_{H^2} L_i(\omega_i) f_r(\omega_i, \omega_o) \cos\theta_i\,
          d\omega_i + \sum_k f_r(\omega_k, \omega_o)\, E_k \cos\theta_k

The sum is over delta lights (directional, point), which are exact. Extended lights are
integrated either by quadrature in (θ, φ) with the sin θ Jacobian, exactly as the lectures write
the integral, or by Monte Carlo with BRDF sampling, light sampling or multiple importance sampling
(balance, power or optimal weights), which returns a standard error beside the value.

References
----------
.. [1] CMU 16-385 Lecture 14; Křivánek, Computer Graphics III; Ramamoorthi, CSE 274 Lecture 2.
.. [2] E. Veach, L. Guibas, "Optimally combining sampling techniques for Monte Carlo
       rendering", SIGGRAPH 1995; E. Veach, PhD thesis, Stanford, 1997, ch. 9.
.. [3] I. Kondapaneni et al., "Optimal multiple importance sampling", ACM TOG 38(4), 2019.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    asarrays,
    check_vectors,
    namespace,
    normalize,
    safe_div,
    to_numpy,
)
from brdfkit.brdf.base import BRDF, Scaled, Sum
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.brdf.one_sided import one_sided_view
from brdfkit.geometry import frame_from_normal, spherical_to_cartesian, to_local, to_world
from brdfkit.light.analytic import UniformSky
from brdfkit.light.base import Light, LightSample
from brdfkit.light.environment import EnvironmentMap
from brdfkit.params import check_choice, param
from brdfkit.sampling import query_seeds, scramble_keys, scrambled_sobol

Method = Literal["auto", "quadrature", "brdf", "light", "mis"]
METHODS = ("auto", "quadrature", "brdf", "light", "mis")
HEURISTICS = ("balance", "power", "optimal")


@dataclass(frozen=True, eq=False)
class Estimate:
    """A value and its standard error (zero for exact and quadrature results), both (..., C)."""

    value: Array
    stderr: Array


Visibility = Callable[[Array, Array, Array], Array]
"""``V(points, wi, distance)``: whether nothing blocks each segment, ``(...,)`` bool."""


def _as_lights(light: Light | Sequence[Light]) -> list[Light]:
    lights = [light] if isinstance(light, Light) else list(light)
    if not lights or not all(isinstance(x, Light) for x in lights):
        raise ValueError(f"light must be a Light or a non-empty sequence of Lights; got {light!r}")
    return lights


def local_frames(wo: Array, normal: Array | None, point: Array | None, tangent: Array | None):
    """The namespace, points, shading frames, ``wo`` in them and the batch shape of a query:
    ``wo`` normalised, ``normal`` (default +z) and ``point`` (default the origin) broadcast to
    one batch, the frames built from the normals (and tangents, where given)."""
    wo = normalize(check_vectors("wo", wo))
    xp = namespace(wo)
    normal = xp.asarray([0.0, 0.0, 1.0], dtype=wo.dtype) if normal is None else normal
    point = xp.asarray([0.0, 0.0, 0.0], dtype=wo.dtype) if point is None else point
    normal = asarray(check_vectors("normal", normal), xp, like=wo)
    point = asarray(check_vectors("point", point), xp, like=wo)
    batch = tuple(np.broadcast_shapes(wo.shape[:-1], normal.shape[:-1], point.shape[:-1]))
    frame = frame_from_normal(xp.broadcast_to(normal, (*batch, 3)), tangent)
    wo_local = to_local(xp.broadcast_to(wo, (*batch, 3)), frame)
    return xp, xp.broadcast_to(point, (*batch, 3)), frame, wo_local, batch


def _expand(frame):
    """A frame broadcast over a new sample axis before the vector axis."""
    return tuple(v[..., None, :] for v in frame)


def reflected_radiance(
    brdf: BRDF,
    light: Light | Sequence[Light],
    wo: Array,
    normal: Array | None = None,
    point: Array | None = None,
    tangent: Array | None = None,
    *,
    method: Method = "auto",
    samples: int = 256,
    heuristic: Literal["balance", "power", "optimal"] = "power",
    theta_steps: int = 64,
    phi_steps: int = 128,
    seed: int | Array | None = 0,
    sequence: Literal["random", "sobol"] = "random",
    first_sample: int = 0,
    visibility: Visibility | None = None,
) -> Estimate:
    """Reflected radiance L_o towards ``wo`` from a surface at ``point`` with ``normal``.

    With ``visibility`` the integrand carries the visibility factor :math:`V(x, \\omega_i)`
    (shadows: :math:`L_o = \\int V L_i f_r \\cos\\theta_i\\,d\\omega_i`), each light and BRDF
    sample, and each delta light, tested by ``visibility(points, wi, distance)``.

    Parameters
    ----------
    brdf : the surface's reflectance (evaluated in the local frame of ``normal``/``tangent``).
    light : one light or several (their contributions add).
    wo : (..., 3) world direction towards the viewer.
    normal, point, tangent : (..., 3) world normal (default +z), position (default origin) and
        optional tangent (for anisotropic BRDFs).
    method : ``"quadrature"`` (θ×φ Gauss–Legendre × midpoint grid of ``theta_steps`` ×
        ``phi_steps`` over the hemisphere), ``"brdf"`` / ``"light"`` (Monte Carlo sampling the
        BRDF / the light; a BSDF samples only its lobe into the lights' hemisphere,
        :func:`~brdfkit.brdf.one_sided.one_sided_view`), ``"mis"`` (both, combined by
        ``heuristic``), or ``"auto"`` (MIS,
        except that Lambertian lobes under an environment map need no samples: see
        :func:`split_diffuse`) and the other lobes sample f − k with the control variate
        k·E(n) exact, :func:`diffuse_floor`). Delta lights are always evaluated exactly.
    samples : Monte Carlo samples per query (per strategy for MIS).
    heuristic : MIS weights: Veach's ``"power"`` (β = 2) or ``"balance"`` heuristic, or
        ``"optimal"`` (Kondapaneni et al. 2019: the balance heuristic with the two pdfs as
        control variates, their coefficients fitted per query; never worse than the better
        strategy alone by more than the fit's noise, and far better where one strategy is
        nearly ideal; BRDFs without delta lobes only). Its standard error treats the fitted
        coefficients as fixed.
    seed : seed of the pseudo-random generator; with ``"sobol"`` also an integer array of
        the batch's shape, one seed per query.
    sequence : ``"random"`` (independent uniforms: the standard error is honest) or ``"sobol"``
        (per query and strategy its own nested-scrambled, digitally shifted Sobol' sequence,
        :func:`~brdfkit.sampling.scrambled_sobol`, keyed by a hash of the query's seed — the
        hash of (``seed``, the query's flat index) for an integer ``seed``: unbiased, much
        lower error for the same ``samples``, e.g. for images; the reported standard error is
        then a conservative over-estimate: estimate it from independent seeds instead).
    first_sample : with ``"sobol"``, the index in each query's sequence of its first sample:
        calls with the same seeds and ``first_sample`` 0, N, 2N, … (N a power of two) draw
        successive blocks of one sequence, whose union is again a scrambled net.
    visibility : ``V(points, wi, distance) -> bool`` (``(...,)``: nothing blocks the segment
        from ``points`` along the world direction ``wi`` up to ``distance``, inf for distant
        lights; a distance of 0 marks a sample whose term is 0 anyway), e.g. shadow rays
        against a mesh (:meth:`brdfkit.render.mesh.MeshScene.visibility`).
        ``"auto"`` then samples every lobe by MIS (the noise-free Lambertian part assumes an
        unoccluded map); ``"quadrature"`` does not take it.

    Returns
    -------
    Estimate with ``value`` and ``stderr`` of shape ``(..., C)``.

    Examples
    --------
    A Lambertian surface (ρ = 0.5) under a directional light of irradiance π at cos θi = 0.8
    reflects ρ/π · π · 0.8 towards every viewer; delta lights are exact:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.light import DirectionalLight, UniformSky
    >>> surface = Lambertian(rho=0.5)
    >>> sun = DirectionalLight((0.0, 0.6, 0.8), irradiance=np.pi)
    >>> estimate = reflected_radiance(surface, sun, np.array([0.0, 0.0, 1.0]))
    >>> estimate.value.round(12).tolist(), estimate.stderr.tolist()
    ([0.4], [0.0])

    Under a uniform sky of radiance 2 it reflects ρ · 2 ("white-out"); quadrature is exact
    here, Monte Carlo comes with its standard error:

    >>> sky = UniformSky(2.0)
    >>> up = np.array([0.0, 0.0, 1.0])
    >>> reflected_radiance(surface, sky, up, method="quadrature").value.round(12).tolist()
    [1.0]
    >>> mc = reflected_radiance(surface, sky, up, method="mis", samples=64)
    >>> bool(abs(mc.value[0] - 1.0) < 3 * mc.stderr[0])
    True
    """
    check_choice("method", method, METHODS)
    if samples < 1:
        raise ValueError(f"samples must be >= 1; got {samples}")
    if sequence not in ("random", "sobol"):
        raise ValueError(f"sequence must be 'random' or 'sobol'; got {sequence!r}")
    check_choice("heuristic", heuristic, HEURISTICS)
    if visibility is not None and method == "quadrature":
        raise ValueError("visibility needs a Monte Carlo method; got method='quadrature'")
    if heuristic == "optimal" and brdf.has_delta:
        raise ValueError(
            "heuristic='optimal' needs a BRDF without delta lobes (their pdf is not a density); "
            f"got {type(brdf).__name__} with one: use 'power' or 'balance'"
        )
    xp, point, frame, wo_local, _ = local_frames(wo, normal, point, tangent)
    rng = _Uniforms(seed, sequence, first_sample)
    rho, rest = split_diffuse(brdf) if method == "auto" else (None, brdf)
    value = stderr2 = None
    for lt in _as_lights(light):
        if method == "auto" and isinstance(lt, EnvironmentMap) and visibility is None:
            v, e2 = 0.0, None
            if rho is not None:
                v = diffuse_envmap_radiance(rho, lt, frame, wo_local)
            mirror, sampled = split_mirror(rest)
            if mirror is not None:
                v = v + _mirror_envmap(mirror, lt, point, frame, wo_local)
            if sampled is not None:
                k = (
                    None
                    if (sampled.has_delta and mirror is None) or heuristic == "optimal"
                    else diffuse_floor(sampled, wo_local)
                )
                v_rest, e2 = _monte_carlo(
                    sampled, lt, point, frame, wo_local, samples, "mis", heuristic, rng, k
                )
                v = v + v_rest
                if k is not None:
                    v = v + diffuse_envmap_radiance(k * math.pi, lt, frame, wo_local)
        elif lt.delta:
            v, e2 = delta_radiance(brdf, lt, point, frame, wo_local, visibility), None
        elif method == "quadrature":
            v, e2 = _quadrature(brdf, lt, point, frame, wo_local, theta_steps, phi_steps), None
        else:
            strategy = "mis" if method == "auto" else method
            v, e2 = _monte_carlo(
                brdf, lt, point, frame, wo_local, samples, strategy, heuristic, rng,
                visibility=visibility,
            )  # fmt: skip
        value = v if value is None else value + v
        if e2 is not None:
            stderr2 = e2 if stderr2 is None else stderr2 + e2
    stderr = xp.zeros_like(value) if stderr2 is None else xp.sqrt(stderr2)
    return Estimate(value, stderr)


def split_diffuse(brdf: BRDF) -> tuple[Array | None, BRDF | None]:
    r"""``brdf`` as ρ/π + the rest: the summed albedo ρ of its Lambertian lobes and the other
    lobes (``None`` for either part that is empty).

    Lambertian lobes are found alone, inside a :class:`~brdfkit.brdf.base.Sum` and inside a
    :class:`~brdfkit.brdf.base.Scaled` (ρ scales by k). Under an environment map their
    reflected radiance is :math:`\rho E(n)/\pi` exactly
    (:meth:`~brdfkit.light.EnvironmentMap.irradiance`), so only the rest needs Monte Carlo;
    its estimator, and so the sum's, stays unbiased.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> rho, rest = split_diffuse(parse("lambertian(rho=0.5) + ggx(alpha=0.3)"))
    >>> rho, type(rest).__name__
    (0.5, 'GGXConductor')
    >>> rho, rest = split_diffuse(parse("0.5 * lambertian(rho=0.8)"))
    >>> float(rho), rest
    (0.4, None)
    """
    if isinstance(brdf, Lambertian):
        return brdf.rho, None
    if isinstance(brdf, Scaled):
        rho, rest = split_diffuse(brdf.inner)
        return (
            None if rho is None else operator.mul(*asarrays(brdf.k, rho)),
            None if rest is None else Scaled(brdf.k, rest),
        )
    if isinstance(brdf, Sum):
        parts = [split_diffuse(lobe) for lobe in brdf.lobes]
        rhos = [rho for rho, _ in parts if rho is not None]
        rests = [rest for _, rest in parts if rest is not None]
        rho = functools.reduce(lambda a, b: operator.add(*asarrays(a, b)), rhos) if rhos else None
        rest = None if not rests else rests[0] if len(rests) == 1 else Sum(tuple(rests))
        return rho, rest
    return None, brdf


def split_mirror(brdf: BRDF | None) -> tuple[BRDF | None, BRDF | None]:
    r"""A smooth plastic (:class:`~brdfkit.brdf.plastic.SmoothPlastic`) as its coating's
    mirror lobe and its diffuse base: ``(brdf, base)``, the base the same model with
    :math:`s = 0` (its sampler then never picks the mirror; its ``eval`` is unchanged,
    since the mirror is a delta ``eval`` does not see). ``(None, brdf)`` for other models.

    Under an environment map the mirror's reflected radiance is
    :math:`s\,F(\cos\theta_o)\,L(\omega_r)` exactly (:func:`_mirror_envmap`), the
    expectation of the sampler's mirror term (chosen with probability p, weight
    :math:`sF/p`), so only the base is sampled: without the random lobe choice, and with the
    control variate :func:`diffuse_floor` (the base has no delta left), which removes the
    variance of the random choice between the coating and the base.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> mirror, base = split_mirror(parse("plastic(specular_reflectance=1.0)"))
    >>> type(mirror).__name__, base.specular_reflectance
    ('SmoothPlastic', 0.0)
    >>> split_mirror(parse("lambertian(rho=0.5)"))[0] is None
    True
    """
    from brdfkit.brdf.plastic import SmoothPlastic

    if isinstance(brdf, SmoothPlastic) and np.any(to_numpy(brdf.specular_reflectance)):
        return brdf, dataclasses.replace(brdf, specular_reflectance=0.0)
    return None, brdf


def _mirror_envmap(mirror: BRDF, env: EnvironmentMap, point: Array, frame, wo_local: Array):
    r""":math:`sF(\cos\theta_o)L(\omega_r)` of :func:`split_mirror`'s mirror towards
    viewers above the surface, else 0, ``(..., C)``."""
    xp = namespace(wo_local)
    r = xp.concat([-wo_local[..., 0:1], -wo_local[..., 1:2], wo_local[..., 2:3]], axis=-1)
    radiance = env.incident_radiance(point, to_world(r, frame))
    albedo = param(mirror.specular_reflectance, wo_local) * mirror._fresnel(wo_local[..., 2:3])
    return xp.where(wo_local[..., 2:3] > 0, albedo * radiance, xp.zeros_like(albedo * radiance))


def diffuse_envmap_radiance(rho: Array, env: EnvironmentMap, frame, wo_local: Array) -> Array:
    """ρ E(n)/π towards viewers above the surface (Lambertian is one-sided), else 0."""
    xp = namespace(wo_local)
    irradiance = env.irradiance(frame[2])
    above = xp.astype(wo_local[..., 2] > 0, wo_local.dtype)[..., None]
    rho = asarray(rho, xp, like=wo_local)
    return rho * irradiance * (above / math.pi)


class _Uniforms:
    """Uniform variates of shape ``batch + (samples, dim)``, one draw per strategy: i.i.d.
    (``"random"``), or points ``first_sample`` … of per-query scrambled Sobol' sequences
    (``"sobol"``, :func:`uniform_keys`), each draw its own stream."""

    def __init__(self, seed: int | Array | None, sequence: str, first_sample: int = 0) -> None:
        if sequence == "random" and np.ndim(seed) > 0:
            raise ValueError("an array of seeds needs sequence='sobol'")
        if first_sample < 0:
            raise ValueError(f"first_sample must be >= 0; got {first_sample}")
        self.seed, self.sequence, self.first = seed, sequence, first_sample
        self.rng = np.random.default_rng(seed) if sequence == "random" else None
        self.stream = 0

    def draw(self, batch: tuple[int, ...], samples: int, dim: int) -> np.ndarray:
        if self.rng is not None:
            return self.rng.random((*batch, samples, dim))
        keys = uniform_keys(self.seed, batch, self.stream, dim)
        self.stream += 1
        return scrambled_sobol(self.first, samples, keys)


def uniform_keys(
    seed: int | Array | None, batch: tuple[int, ...], stream: int, dim: int
) -> np.ndarray:
    """The :func:`~brdfkit.sampling.scrambled_sobol` keys ``batch + (2, dim)`` of a batch of
    queries for their ``stream``-th point set: from one seed per query (an integer array of
    shape ``batch``), or from an integer ``seed`` by :func:`~brdfkit.sampling.query_seeds`
    (``None``: a fresh random one)."""
    return scramble_keys(uniform_seeds(seed, batch), stream, dim)


def uniform_seeds(seed: int | Array | None, batch: tuple[int, ...]) -> np.ndarray:
    """The 64-bit seeds ``batch`` of a batch of queries (:func:`uniform_keys`): ``seed``
    itself (an integer array of shape ``batch``), or from an integer by
    :func:`~brdfkit.sampling.query_seeds` (``None``: a fresh random one)."""
    if seed is None:
        seed = int(np.random.default_rng().integers(2**63))
    if np.ndim(seed) == 0:
        return query_seeds(int(seed), math.prod(batch)).reshape(batch)
    seeds = np.asarray(to_numpy(seed))
    if seeds.shape != tuple(batch) or not np.issubdtype(seeds.dtype, np.integer):
        raise ValueError(
            f"seed must be an integer or an integer array of shape {tuple(batch)}; "
            f"got {seeds.dtype} {seeds.shape}"
        )
    return seeds


def _light_term(
    brdf: BRDF, ls: LightSample, frame, wo_local: Array, control: Array | None = None
) -> tuple[Array, Array]:
    """(f(wi, wo) − k)·value·max(cos θi, 0) of a light sample (k = ``control`` or 0), and wi
    in the local frame."""
    xp = namespace(wo_local)
    wi_local = to_local(ls.wi, frame)
    cos_theta_i = xp.maximum(wi_local[..., 2], xp.zeros_like(wi_local[..., 2]))
    f = brdf.eval(wi_local, wo_local)
    if control is not None:
        f = f - control[..., None, :]
    return f * ls.value * cos_theta_i[..., None], wi_local


def delta_radiance(
    brdf: BRDF,
    light: Light,
    point: Array,
    frame,
    wo_local: Array,
    visibility: Visibility | None = None,
) -> Array:
    """The radiance a delta light (directional, point) reflects towards ``wo_local``:
    :math:`V\\,f(\\omega_i, \\omega_o)\\,E_\\perp\\cos\\theta_i`, ``(..., C)`` (V = 1 without
    ``visibility``)."""
    ls = light.sample(point, None)
    term = _light_term(brdf, ls, frame, wo_local)[0]
    return term if visibility is None else _shadowed(term, visibility, point, ls.wi, ls.distance)


def _shadowed(term: Array, visibility: Visibility, points: Array, wi: Array, distance) -> Array:
    """``term`` (``(..., C)``) where ``visibility`` sees the light, else 0; a zero term asks
    for no ray (its distance is given as 0)."""
    xp = namespace(term)
    distance = xp.broadcast_to(asarray(distance, xp, like=term), wi.shape[:-1])
    distance = xp.where(xp.any(term != 0, axis=-1), distance, xp.zeros_like(distance))
    visible = asarray(visibility(points, wi, distance), xp, like=term)
    return term * visible[..., None]


def _polar_nodes(steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes θ and weights on [0, π/2]."""
    nodes, weights = np.polynomial.legendre.leggauss(steps)
    return (nodes + 1) * (math.pi / 4), weights * (math.pi / 4)


def _quadrature(brdf, light, point, frame, wo_local, theta_steps: int, phi_steps: int) -> Array:
    """Σ L_i f cosθ sinθ Δθ Δφ over a Gauss–Legendre (θ) × midpoint (φ) grid."""
    xp = namespace(wo_local)
    theta, w_theta = _polar_nodes(theta_steps)
    phi = (np.arange(phi_steps) + 0.5) * (2 * math.pi / phi_steps)
    theta_g, phi_g = np.meshgrid(theta, phi, indexing="ij")
    jacobian = (
        w_theta[:, None] * np.sin(theta_g) * np.cos(theta_g) * (2 * math.pi / phi_steps)
    ).ravel()
    d_local = asarray(spherical_to_cartesian(theta_g.ravel(), phi_g.ravel()), xp, like=wo_local)
    jac = asarray(jacobian, xp, like=wo_local)
    wi_world = to_world(d_local, _expand(frame))
    radiance = light.incident_radiance(point[..., None, :], wi_world)
    f = brdf.eval(d_local, wo_local[..., None, :])
    return xp.sum(f * radiance * jac[:, None], axis=-2)


def _power(p: Array, heuristic: str) -> Array:
    return p * p if heuristic == "power" else p


FLOOR_DIRECTIONS = 16
"""Directions at which :func:`diffuse_floor` evaluates a BRDF."""


@functools.cache
def _floor_directions(count: int) -> np.ndarray:
    """``count`` fixed local directions spread over the hemisphere by cosine weight (a
    Fibonacci spiral warped by Malley's method), ``(count, 3)``."""
    i = np.arange(count) + 0.5
    r = np.sqrt(i / count)
    phi = i * (math.pi * (3 - math.sqrt(5)))
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - r * r)], axis=-1)


def diffuse_floor(brdf: BRDF, wo_local: Array) -> Array:
    r"""A constant :math:`k(\omega_o)` per channel under ``brdf``'s value: the median over
    :data:`FLOOR_DIRECTIONS` fixed directions of :math:`f(\omega_j, \omega_o)`, ``(..., C)``.

    The control variate of ``method="auto"`` under an environment map:

    .. math:: L_o = k\,E(n) + \int (f - k)\,L\cos\theta_i\,d\omega_i,

    exact for any k that does not depend on the samples (E from
    :meth:`~brdfkit.light.EnvironmentMap.irradiance`), so only :math:`f - k` is sampled.
    Where f is nearly constant (rough diffuse lobes, the diffuse floor under a highlight) the
    remainder, and the variance with it, is small; the median ignores a highlight, so for a
    glossy lobe k is its small floor and the estimator stays the plain MIS one.

    References
    ----------
    .. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §2.2.5
           (control variates).
    .. [2] R. Ramamoorthi, P. Hanrahan, SIGGRAPH 2001 (the irradiance E(n)).

    Examples
    --------
    A Lambertian lobe is its own floor, ρ/π; so nothing of it is left to sample:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> k = diffuse_floor(Lambertian(rho=0.5), np.array([0.0, 0.0, 1.0]))
    >>> (k * np.pi).round(12).tolist()
    [0.5]
    """
    xp = namespace(wo_local)
    directions = asarray(_floor_directions(FLOOR_DIRECTIONS), xp, like=wo_local)
    f = brdf.eval(directions, wo_local[..., None, :])  # (..., J, C)
    median = xp.sort(f, axis=-2)[..., FLOOR_DIRECTIONS // 2, :]
    return xp.maximum(median, xp.zeros_like(median))


def _monte_carlo(
    brdf,
    light,
    point,
    frame,
    wo_local,
    samples,
    strategy,
    heuristic,
    rng,
    control=None,
    visibility: Visibility | None = None,
):
    xp = namespace(wo_local)
    # only wi above the surface count: a BSDF samples its lobe into that hemisphere alone
    brdf = one_sided_view(brdf)
    if strategy == "mis" and isinstance(light, EnvironmentMap):
        light = light.compensated  # BRDF sampling covers the map's mean (MIS compensation)
    batch = wo_local.shape[:-1]
    wo_n = xp.broadcast_to(wo_local[..., None, :], (*batch, samples, 3))
    point_n = xp.broadcast_to(point[..., None, :], (*batch, samples, 3))
    frame_n = _expand(frame)
    contributions = None

    if strategy in ("brdf", "mis"):
        # three uniforms: BSDFs choose reflection or refraction with the third
        u = asarray(rng.draw(batch, samples, 3), xp, like=wo_local)
        s = brdf.sample(wo_n, u)
        wi_world = to_world(s.wi, frame_n)
        radiance = light.incident_radiance(point_n, wi_world)
        upper = (s.wi[..., 2] > 0)[..., None]
        weight = s.weight
        if control is not None:  # (f − k)·cos/p
            cos_over_p = safe_div(s.wi[..., 2], s.pdf)[..., None]
            weight = weight - control[..., None, :] * cos_over_p
        c_b = xp.where(upper, weight * radiance, xp.zeros_like(weight * radiance))
        if visibility is not None:
            c_b = _shadowed(c_b, visibility, point_n, wi_world, math.inf)
        if strategy == "brdf":
            contributions = c_b
        else:
            pdfs_b = (s.pdf, light.pdf(point_n, wi_world))  # (p_brdf, p_light) at BRDF samples

    if strategy in ("light", "mis"):
        u = asarray(rng.draw(batch, samples, 2), xp, like=wo_local)
        ls = light.sample(point_n, u)
        c_l, wi_local = _light_term(brdf, ls, frame_n, wo_n, control)
        if visibility is not None:
            c_l = _shadowed(c_l, visibility, point_n, ls.wi, ls.distance)
        if strategy == "light":
            contributions = c_l
        else:
            pdfs_l = (brdf.pdf(wi_local, wo_n), ls.pdf)

    if strategy == "mis" and heuristic == "optimal":
        contributions = _optimal_mis(c_b, pdfs_b, c_l, pdfs_l)
    elif strategy == "mis":
        # The two strategies' per-sample contributions add into one estimator.
        p_b, p_l = (_power(p, heuristic) for p in pdfs_b)
        w_b = xp.where(s.delta, xp.ones_like(p_b), safe_div(p_b, p_b + p_l))
        p_b, p_l = (_power(p, heuristic) for p in pdfs_l)
        contributions = c_b * w_b[..., None] + c_l * safe_div(p_l, p_b + p_l)[..., None]

    mean = xp.mean(contributions, axis=-2)
    deviation = contributions - mean[..., None, :]  # two passes: no cancellation
    return mean, xp.mean(deviation * deviation, axis=-2) / samples


def _optimal_mis(
    c_b: Array, pdfs_b: tuple[Array, Array], c_l: Array, pdfs_l: tuple[Array, Array]
) -> Array:
    r"""Per-sample-pair terms of the optimal MIS estimator of Kondapaneni et al. (2019).

    With N samples of each strategy, the optimal weights turn MIS into the balance heuristic
    applied to :math:`g - \alpha_b p_b - \alpha_l p_l` plus the integral of
    :math:`\alpha_b p_b + \alpha_l p_l`: the pdfs are control variates. Their coefficients
    solve the 2×2 least-squares problem :math:`\min \sum (g - \alpha\cdot p)^2/(p_b + p_l)^2`
    over all samples, per query and channel (the paper's :math:`A\alpha = b`, estimated from
    the same samples: a bias of order 1/N, measured below the noise). With α = 0 the terms are
    the balance heuristic's; where one strategy is nearly ideal (g ∝ its pdf) the residual and
    the variance vanish, which no fixed heuristic achieves (Veach's bound).

    ``c_*`` are the strategies' one-sample estimates g/p, ``(..., n, C)``; ``pdfs_*`` the BRDF
    and light densities at their samples, ``(..., n)``. Returns ``(..., n, C)`` terms whose mean
    is the estimate.

    References
    ----------
    .. [1] I. Kondapaneni, P. Vévoda, P. Grittmann, T. Skřivan, P. Slusallek, J. Křivánek,
           "Optimal multiple importance sampling", ACM TOG 38(4), 2019, eqs. 11-16.
    """
    xp = namespace(c_b, c_l)
    rows = []  # per strategy: features φ = p/(p_b + p_l), (..., n, 2), and targets g/(p_b + p_l)
    for c, (p_b, p_l), p_own in ((c_b, pdfs_b, pdfs_b[0]), (c_l, pdfs_l, pdfs_l[1])):
        mixture = p_b + p_l
        phi = xp.stack([safe_div(p_b, mixture), safe_div(p_l, mixture)], axis=-1)
        rows.append((phi, c * safe_div(p_own, mixture)[..., None]))
    a = sum(xp.sum(phi[..., :, None] * phi[..., None, :], axis=-3) for phi, _ in rows)
    b = sum(xp.sum(phi[..., :, None] * y[..., None, :], axis=-3) for phi, y in rows)
    alpha = _solve_2x2(a, b)[..., None, :, :]  # (..., 1, 2, C)
    # ∫α·p is α·(the probability that each sampler returns a direction of nonzero density):
    # BRDF samplers also return directions below the surface, where the pdf is 0 (1-4 % for
    # GGX). Each strategy's own samples estimate it, as indicators added to the terms.
    terms = alpha[..., 0, :] * asarray(pdfs_b[0] > 0, xp, like=c_b)[..., None]
    terms = terms + alpha[..., 1, :] * asarray(pdfs_l[1] > 0, xp, like=c_b)[..., None]
    for phi, y in rows:
        terms = terms + y - xp.sum(phi[..., :, None] * alpha, axis=-2)
    return terms


def _solve_2x2(a: Array, b: Array) -> Array:
    """α = A⁻¹b for symmetric A ``(..., 2, 2)`` and b ``(..., 2, C)``, with a ridge of 10⁻¹²
    trace(A) so that collinear pdfs give a bounded answer (0 where A = 0)."""
    xp = namespace(a, b)
    ridge = 1e-12 * (a[..., 0, 0] + a[..., 1, 1])
    a00, a11, a01 = a[..., 0, 0] + ridge, a[..., 1, 1] + ridge, a[..., 0, 1]
    det = (a00 * a11 - a01 * a01)[..., None]
    alpha_b = safe_div(a11[..., None] * b[..., 0, :] - a01[..., None] * b[..., 1, :], det)
    alpha_l = safe_div(a00[..., None] * b[..., 1, :] - a01[..., None] * b[..., 0, :], det)
    return xp.stack([alpha_b, alpha_l], axis=-2)


def directional_albedo(brdf: BRDF, wo: Array, **kwargs) -> Estimate:
    """Directional-hemispherical reflectance ρ(wo) = ∫ f cos θi dωi, as L_o under a unit sky.

    ``wo`` is in the local frame (+z the normal); keyword arguments go to
    :func:`reflected_radiance` (``method="quadrature"`` gives a deterministic value).

    Examples
    --------
    A Lambertian surface reflects ρ at every angle; a rough metal a little less than 1 (the
    energy lost to single scattering):

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian, parse
    >>> wo = np.array([[0.0, 0.0, 1.0], [0.8, 0.0, 0.6]])
    >>> directional_albedo(Lambertian(rho=0.5), wo, method="quadrature").value.round(12).tolist()
    [[0.5], [0.5]]
    >>> rho = directional_albedo(parse("ggx(alpha=0.3)"), wo[0], method="quadrature").value
    >>> rho.round(3).tolist()
    [0.877]
    """
    return reflected_radiance(brdf, UniformSky(1.0), wo, **kwargs)


def hemispherical_reflectance(brdf: BRDF, theta_steps: int = 32, **kwargs) -> Array:
    r"""Bihemispherical reflectance, the cosine-weighted mean of the directional albedo.

    :math:`\rho_{hh} = \frac1\pi\int\rho(\omega_o)\cos\theta_o\,d\omega_o`.

    For an isotropic BRDF ρ depends on θo only: Gauss–Legendre over θo of
    2 ρ(θo) cos θo sin θo. Keyword arguments go to :func:`directional_albedo`.

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> hemispherical_reflectance(Lambertian(rho=0.5), 8, method="quadrature").round(12).tolist()
    [0.5]
    """
    theta, w_theta = _polar_nodes(theta_steps)
    wo = spherical_to_cartesian(theta, np.zeros_like(theta))
    rho = directional_albedo(brdf, wo, **kwargs).value
    xp = namespace(rho)
    w = asarray(2 * w_theta * np.cos(theta) * np.sin(theta), xp, like=rho)
    return xp.sum(rho * w[:, None], axis=0)


__all__ = [
    "FLOOR_DIRECTIONS",
    "HEURISTICS",
    "METHODS",
    "Estimate",
    "delta_radiance",
    "diffuse_envmap_radiance",
    "diffuse_floor",
    "directional_albedo",
    "hemispherical_reflectance",
    "local_frames",
    "reflected_radiance",
    "split_diffuse",
    "split_mirror",
]
