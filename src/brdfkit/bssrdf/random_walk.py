r"""The reference: a Monte Carlo random walk in a homogeneous medium below a smooth boundary.

Collimated light arrives from outside at :math:`\mu_i = \cos\theta_i` on a medium filling
:math:`0 \le z < d` (:math:`d = \infty`: a half-space) below a smooth dielectric boundary of
relative index η. The walk is the analog simulation of the radiative transfer equation, in
units of the mean free path (:math:`\sigma_t = 1`):

1. the boundary transmits :math:`T_i = 1 - F(\mu_i)` of the power (:func:`brdfkit.fresnel.
   fresnel`; the specular reflection :math:`F(\mu_i)` is not counted), refracted by Snell's
   law;
2. a free path :math:`s = -\ln u` is drawn;
3. a path reaching the top (or, in a slab, the bottom) boundary there meets the Fresnel
   reflectance of light from inside, :math:`F(-|\mu|)` (1 under total internal reflection):
   it is reflected with that probability and leaves otherwise;
4. at a collision the walk is absorbed with probability 1 − ω, else it scatters by the phase
   function (:func:`~brdfkit.bssrdf.medium.sample_henyey_greenstein`, a uniform azimuth).

Each walk is a Bernoulli trial that leaves the top at radius r (its distance from the point
of entry) or not, so the diffuse reflectance :math:`R = T_i\,\hat p` and its standard error
:math:`T_i\sqrt{\hat p(1-\hat p)/(N-1)}` follow from the fraction :math:`\hat p` of N walks
that leave the top, and the radial exitance profile (per unit area, per unit incident power)
from a histogram of their radii: :math:`R(r) = T_i\,N_b/(N\,\pi(r_{b+1}^2 - r_b^2))`, with
:math:`2\pi\int_0^\infty R(r)\,r\,dr = R`. The walk is exact (no diffusion approximation):
at η = 1 with isotropic scattering it reproduces Chandrasekhar's
:func:`~brdfkit.bssrdf.chandrasekhar.chandrasekhar_reflectance` within its standard error
(tested).

The walk's uniforms are a counter-based hash (:func:`brdfkit.sampling.key_hash`) of the
walk's seed (:func:`brdfkit.sampling.query_seeds` of ``seed`` and the walk's index) and of a
slot per event, so a run is the same however it is split over threads, and
``_random_walk_kernels.py`` (the compiled walk) repeats :func:`walk_reference` walk for walk.

References
----------
.. [1] L. Wang, S. L. Jacques, L. Zheng, "MCML — Monte Carlo modeling of light transport in
       multi-layered tissues", Computer Methods and Programs in Biomedicine 47, 131–146, 1995.
.. [2] S. Chandrasekhar, *Radiative Transfer*, 1950.
.. [3] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 3rd ed., §15.2 (sampling media), 2016.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit import sampling
from brdfkit._array import check_param
from brdfkit._checks import as_float_array, check_count
from brdfkit.bssrdf._random_walk_kernels import SLOTS, UNIT, walk_kernel
from brdfkit.bssrdf.medium import ALBEDO, ASYMMETRY, INDEX, sample_henyey_greenstein
from brdfkit.compiled.kernel_tools import run_tasks, threads
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel, fresnel_dielectric
from brdfkit.geometry import frame_from_normal, to_world
from brdfkit.params import Domain, described

MAX_EVENTS = 1_000_000
"""Events after which a walk is stopped and counted as lost (``truncated``): only a
conservative medium (ω ≈ 1) sees walks that long."""

MAX_SAMPLES = 2_000_000_000
"""The most walks one call runs."""

CHUNK = 1 << 16
"""Walks a thread takes at a time (the seeds of a chunk and its walks' outcomes in memory)."""

THICKNESS = Domain(0.0, math.inf, lo_open=True, hint="slab thickness in mean free paths")

ABSORBED, REFLECTED, TRANSMITTED, LOST = 0, 1, 2, 3
"""How a walk ends: absorbed, leaving through the top, through the bottom, or stopped."""


# --------------------------------------------------------------------------- the reference walk
def uniforms(seeds: np.ndarray, slots: Any) -> np.ndarray:
    r"""The walks' uniforms :math:`(h + \tfrac12)\,2^{-32}` in (0, 1) at ``slots``, from the
    32-bit hashes h of :func:`brdfkit.sampling.key_hash` of each walk's seed and slot."""
    hashes = sampling.key_hash(np.asarray(seeds, np.uint64), np.asarray(slots, np.uint64))
    return (hashes.astype(np.float64) + 0.5) * UNIT


def entry(cos_theta_i: float, eta: float) -> tuple[float, tuple[float, float]]:
    """``(T, (dx, dz))``: the power the boundary transmits, :math:`1 - F(\\mu_i)`, and the
    refracted direction (x lateral, z the depth) of light arriving at ``cos_theta_i``."""
    f, cos_theta_t, _, eta_ti = fresnel(cos_theta_i, eta)
    sin_theta_i = math.sqrt(max(1.0 - cos_theta_i * cos_theta_i, 0.0))
    return 1.0 - float(f), (-float(eta_ti) * sin_theta_i, -float(cos_theta_t))


def walk_reference(
    seeds: np.ndarray,
    albedo: float,
    eta: float,
    g: float,
    thickness: float,
    direction: tuple[float, float],
    max_events: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One walk per 64-bit seed, all walks a step at a time in NumPy (steps 2–4 of the module
    docstring).

    Returns
    -------
    side : int8, how each walk ended (:data:`ABSORBED`, :data:`REFLECTED`,
        :data:`TRANSMITTED` or :data:`LOST`).
    radius : the distance from the point of entry at which it ended.
    events : its number of events (free paths).
    """
    n = seeds.shape[0]
    position = np.zeros((n, 3))
    travel = np.tile([direction[0], 0.0, direction[1]], (n, 1))
    side = np.full(n, LOST, np.int8)
    events = np.full(n, max_events, np.int64)
    live = np.arange(n)
    for k in range(max_events):
        if live.size == 0:
            break
        ended = _step(seeds[live], k, position, travel, live, (albedo, eta, g, thickness))
        for code, mask in ended.items():
            side[live[mask]], events[live[mask]] = code, k + 1
        live = live[~np.logical_or.reduce(list(ended.values()))]
    return side, np.hypot(position[:, 0], position[:, 1]), events


def _step(
    seeds: np.ndarray,
    k: int,
    position: np.ndarray,
    travel: np.ndarray,
    live: np.ndarray,
    medium: tuple[float, float, float, float],
) -> dict[int, np.ndarray]:
    """Event ``k`` of the ``live`` walks, in place on ``position`` and ``travel``; the masks
    (over ``live``) of the walks it ends, by how they end."""
    albedo, eta, g, thickness = medium
    p, d = position[live], travel[live]
    free = -np.log(uniforms(seeds, SLOTS * k))
    decision = uniforms(seeds, SLOTS * k + 1)
    depth = p[:, 2] + free * d[:, 2]
    top = (d[:, 2] < 0) & (depth <= 0)
    bottom = ~top & (d[:, 2] > 0) & (depth >= thickness)
    inside = ~top & ~bottom
    wall = np.where(top, 0.0, thickness)
    to_wall = np.where(top | bottom, (wall - p[:, 2]) / np.where(inside, 1.0, d[:, 2]), free)
    p = p + to_wall[:, None] * d
    p[~inside, 2] = wall[~inside]
    reflectance = fresnel_dielectric(-np.abs(d[:, 2]), eta)
    leaves = ~inside & (decision >= reflectance)
    absorbed = inside & (decision >= albedo)
    d[~inside, 2] = -d[~inside, 2]  # reflected (those that leave end here)
    scatters = inside & ~absorbed
    if np.any(scatters):
        cos_theta = sample_henyey_greenstein(uniforms(seeds[scatters], SLOTS * k + 2), g)
        phi = 2 * np.pi * uniforms(seeds[scatters], SLOTS * k + 3)
        sin_theta = np.sqrt(np.maximum(1 - cos_theta * cos_theta, 0.0))
        local = np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], -1)
        d[scatters] = to_world(local, frame_from_normal(d[scatters]))
    position[live], travel[live] = p, d
    return {REFLECTED: leaves & top, TRANSMITTED: leaves & bottom, ABSORBED: absorbed}


# --------------------------------------------------------------------------- tallies
@dataclass(frozen=True)
class RadialProfile:
    r"""The radial exitance profile of a random walk: per radial bin
    :math:`[r_b, r_{b+1})`, the exitance :math:`R(r)` (per unit area, per unit incident power)
    and its standard error; ``total`` and ``total_stderr`` are the whole diffuse reflectance
    (all radii, also beyond the last edge)."""

    edges: np.ndarray
    exitance: np.ndarray
    stderr: np.ndarray
    total: float
    total_stderr: float

    @property
    def radii(self) -> np.ndarray:
        """The bins' centres."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])


@dataclass(frozen=True)
class WalkTally:
    """What N walks did: how many left the top (and their radii, binned at ``edges``), how
    many left through the bottom, how many were stopped; and :math:`T_i`, the power that
    entered."""

    samples: int
    transmitted_in: float
    reflected: int
    transmitted: int
    lost: int
    edges: np.ndarray
    counts: np.ndarray

    def _fraction(self, count: int) -> tuple[float, float]:
        p, n = count / self.samples, self.samples
        spread = math.sqrt(p * (1 - p) / (n - 1)) if n > 1 else math.inf
        return self.transmitted_in * p, self.transmitted_in * spread

    def reflectance(self) -> tuple[float, float]:
        """The diffuse reflectance and its standard error."""
        return self._fraction(self.reflected)

    def transmittance(self) -> tuple[float, float]:
        """The diffuse transmittance of a slab (0 for a half-space) and its standard error."""
        return self._fraction(self.transmitted)

    def profile(self) -> RadialProfile:
        """The radial exitance profile (:class:`RadialProfile`)."""
        area = np.pi * np.diff(self.edges**2)
        p = self.counts / self.samples
        spread = np.sqrt(p * (1 - p) / max(self.samples - 1, 1))
        total, total_stderr = self.reflectance()
        t = self.transmitted_in
        return RadialProfile(self.edges, t * p / area, t * spread / area, total, total_stderr)


# --------------------------------------------------------------------------- the pipeline
def tally_walks(
    albedo: float,
    eta: float,
    cos_theta_i: float,
    samples: int,
    seed: int = 0,
    *,
    g: float = 0.0,
    thickness: float = math.inf,
    edges: Any = None,
    compiled: bool = True,
) -> WalkTally:
    """Run ``samples`` walks (module docstring) and tally them.

    Parameters
    ----------
    albedo : single-scattering albedo ω in [0, 1].
    eta : relative index of the boundary, :math:`n_\\text{inside}/n_\\text{outside}` > 0.
    cos_theta_i : cosine of the collimated light's direction, in (0, 1].
    samples : number of walks (at most :data:`MAX_SAMPLES`).
    seed : the run's seed (≥ 0); the same seed gives the same walks.
    g : Henyey–Greenstein asymmetry in (−1, 1).
    thickness : depth of the slab in mean free paths (``inf``: a half-space).
    edges : increasing radii (mean free paths) of the profile's bins, from ≥ 0; ``None``
        tallies no profile.
    compiled : run the numba kernel (``False``: :func:`walk_reference`, for small runs).

    Returns
    -------
    WalkTally

    Examples
    --------
    >>> tally = tally_walks(0.9, 1.0, 1.0, 2000, seed=1, edges=[0.0, 1.0, 2.0])
    >>> value, stderr = tally.reflectance()
    >>> 0.35 < value < 0.48 and stderr < 0.02
    True
    """
    albedo = float(ALBEDO.check("albedo", albedo))
    eta = float(INDEX.check("eta", eta))
    cos_theta_i = float(check_param("cos_theta_i", cos_theta_i, 0.0, 1.0, lo_open=True))
    g = float(ASYMMETRY.check("g", g))
    samples = check_count("samples", samples, MAX_SAMPLES, minimum=2)
    seed = check_count("seed", seed, 2**63, minimum=0)
    if thickness != math.inf:
        thickness = float(THICKNESS.check("thickness", thickness))
    edges = _edges(edges)
    transmitted_in, direction = entry(cos_theta_i, eta)
    walk = walk_kernel if compiled else walk_reference
    chunks = range(0, samples, CHUNK)
    tallies: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def run(first: int) -> None:
        seeds = sampling.query_seeds(seed, min(CHUNK, samples - first), first)
        side, radius, _ = walk(seeds, albedo, eta, g, float(thickness), direction, MAX_EVENTS)
        counts = np.histogram(radius[side == REFLECTED], edges)[0]
        tallies[first] = np.bincount(side, minlength=4), counts

    run_tasks(run, chunks, threads() if compiled else 1)
    ends = sum(tallies[first][0] for first in chunks)
    counts = sum(tallies[first][1] for first in chunks)
    return WalkTally(
        samples, transmitted_in, int(ends[REFLECTED]), int(ends[TRANSMITTED]), int(ends[LOST]),
        edges, np.asarray(counts, np.int64),
    )  # fmt: skip


def _edges(edges: Any) -> np.ndarray:
    if edges is None:
        return np.array([0.0, math.inf])
    edges = as_float_array("edges", edges, finite=False)  # the last may be inf
    increasing = edges.ndim == 1 and edges.size >= 2 and bool(np.all(np.diff(edges) > 0))
    if not increasing or not edges[0] >= 0:
        raise ParameterError(
            f"edges must be two or more increasing radii from 0 up; got {described(edges)}"
        )
    return edges


def random_walk_reflectance(
    albedo: float,
    eta: float,
    cos_theta_i: float,
    samples: int,
    seed: int = 0,
    g: float = 0.0,
    thickness: float = math.inf,
) -> tuple[float, float]:
    """The diffuse reflectance of collimated light and its standard error, by :func:`tally_walks`
    (the specular reflection at the boundary not included).

    Examples
    --------
    >>> value, stderr = random_walk_reflectance(0.5, 1.0, 1.0, 4000, seed=2)
    >>> abs(value - 0.1152) < 4 * stderr
    True
    """
    return tally_walks(
        albedo, eta, cos_theta_i, samples, seed, g=g, thickness=thickness
    ).reflectance()


def random_walk_profile(
    albedo: float,
    eta: float,
    cos_theta_i: float,
    samples: int,
    edges: Any,
    seed: int = 0,
    g: float = 0.0,
    thickness: float = math.inf,
) -> RadialProfile:
    """The radial exitance profile R(r) at the bins ``edges`` (mean free paths), with the total
    diffuse reflectance, by :func:`tally_walks`.

    Examples
    --------
    >>> profile = random_walk_profile(0.99, 1.33, 1.0, 3000, edges=[0.0, 0.5, 1.0, 4.0])
    >>> bool(profile.exitance[0] > profile.exitance[-1])
    True
    """
    tally = tally_walks(
        albedo, eta, cos_theta_i, samples, seed, g=g, thickness=thickness, edges=edges
    )
    return tally.profile()


__all__ = [
    "ABSORBED",
    "CHUNK",
    "LOST",
    "MAX_EVENTS",
    "MAX_SAMPLES",
    "REFLECTED",
    "TRANSMITTED",
    "RadialProfile",
    "WalkTally",
    "entry",
    "random_walk_profile",
    "random_walk_reflectance",
    "tally_walks",
    "uniforms",
    "walk_reference",
]
