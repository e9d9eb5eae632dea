r"""Consensus photometric stereo: normals from the order of the intensities (Higo et al. 2010).

For a large class of reflectances the brightness of a point grows as the light approaches its
normal (*monotonicity*), and a point is dark exactly where the light is behind it
(*visibility*). Neither depends on the BRDF's form, so the normal is the one whose cosines
``n·l_k`` agree best with the observations in these two respects::

    cost(n) = (1 - ρ_S(I, n·L)) / 2 + mean_k | [I_k lit] - [n·l_k > 0] |,

``ρ_S`` the Spearman rank correlation over the lit observations (brighter than
``shadow_threshold`` times the pixel's 90th-percentile observation) and the second term the
fraction of observations whose visibility disagrees. The search is global: every pixel is
scored against a Fibonacci set of ``candidates`` directions on the front hemisphere (rank
correlations against shared candidates: one matrix product, the other sums over the lit
lights in a compiled kernel, all exact sums of integers), then refined by hill climbing on
rings of decreasing radius around the best (4°, 2°, 1°, 0.5°, 0.25°; six trial normals a ring,
each kept if its cost is lower), pixel by pixel in a compiled kernel
(:mod:`brdfkit.vision._photometric_stereo_kernels`; a trial's ranks insertion-sort the previous
order).

Higo et al. also use an isotropy constraint and a Markov random field over the image to
smooth the per-pixel choices; both are omitted here (each pixel is solved alone), so this is
the per-pixel consensus of the monotonicity and visibility constraints.

References
----------
.. [1] T. Higo, Y. Matsushita, K. Ikeuchi, "Consensus photometric stereo", CVPR 2010.
.. [2] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019 (HM10 on
   DiLiGenT).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import check_count
from brdfkit.errors import ParameterError
from brdfkit.vision.bivariate_stereo import _finish, _reference
from brdfkit.vision.photometric_stereo import (
    BLAS_THREADS,
    Callback,
    PhotometricStereoResult,
    _gray,
    _prepare,
)

MAX_CANDIDATES = 100_000
"""Most candidate directions of the global search."""

_BLOCK = 4096
"""Pixels scored together against the candidates (bounds the (pixels, candidates) temporaries)."""

_RINGS = np.radians([4.0, 2.0, 1.0, 0.5, 0.25])


def _ranks(values: np.ndarray) -> np.ndarray:
    """Ranks 0 … N-1 along the last axis (ties in index order), float64."""
    order = np.argsort(values, axis=-1)
    ranks = np.empty(values.shape)
    np.put_along_axis(ranks, order, np.broadcast_to(np.arange(values.shape[-1]), values.shape), -1)
    return ranks


def _hemisphere(count: int) -> np.ndarray:
    """``count`` Fibonacci-lattice unit vectors on the front hemisphere ``z > 0``."""
    k = np.arange(count) + 0.5
    z = 1 - k / count
    r = np.sqrt(1 - z * z)
    phi = k * np.pi * (3 - np.sqrt(5))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _global_search(
    ranks: np.ndarray, lit: np.ndarray, lights: np.ndarray, candidates: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Best candidate per pixel by the consensus cost, with ranks of the candidates' cosines
    over all lights (the weighted Pearson correlation of ranks); returns the normals ``(P, 3)``
    and their lights sorted by cosine ``(P, N)`` (the start of the rings' sorts).

    The sums over the lit lights ``sum_k lit_k ranks_k R_ck`` are a matrix product (BLAS, one
    thread: see :data:`~brdfkit.vision.photometric_stereo.BLAS_THREADS`; in single precision
    when every partial sum is an integer below ``2^24``, so exactly), the rest and the cost
    are :func:`brdfkit.vision._photometric_stereo_kernels.consensus_best`, pixels over the cores.
    """
    from threadpoolctl import threadpool_limits

    from brdfkit.vision import _photometric_stereo_kernels

    cosines = candidates @ lights.T  # (M, N)
    candidate_ranks = _ranks(cosines)
    front = (cosines > 0).astype(np.float64)
    tables = np.ascontiguousarray(np.stack([candidate_ranks.T, candidate_ranks.T**2, front.T]))
    totals = tables.sum(axis=1)
    n_lights = lights.shape[0]
    exact32 = n_lights * (n_lights - 1) ** 2 < 2**24  # the largest sum of rank products
    dtype = np.float32 if exact32 else np.float64
    ranks_t = np.ascontiguousarray(candidate_ranks.T, dtype=dtype)
    best = np.empty(len(ranks), np.int64)
    with threadpool_limits(BLAS_THREADS, user_api="blas"):
        for start in range(0, len(ranks), _BLOCK):
            r, w = ranks[start : start + _BLOCK], lit[start : start + _BLOCK]
            products = (w * r).astype(dtype) @ ranks_t
            best[start : start + _BLOCK] = _photometric_stereo_kernels.consensus_best(
                w, r, products, tables, totals
            )
    return candidates[best], np.argsort(cosines, axis=1)[best]


def consensus(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    candidates: int = 800,
    shadow_threshold: float = 0.05,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    """Photometric stereo by the consensus of monotonicity and visibility (Higo et al. 2010).

    See the module docstring for the cost and the search. The albedo is the diffuse one along
    the found normals (as :mod:`brdfkit.vision.bivariate_stereo` reports it).

    Parameters
    ----------
    images, light_directions, mask : as :func:`~brdfkit.vision.photometric_stereo.least_squares`.
    candidates : directions of the global search (16 … :data:`MAX_CANDIDATES`); 800 are about
        5° apart.
    shadow_threshold : fraction of a pixel's 90th-percentile observation below which an
        observation is a shadow,
        in [0, 1).
    callback : ``callback(step, steps)`` after the global search and each ring.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask, or ``shadow_threshold`` outside [0, 1).
    brdfkit.errors.ResourceError
        ``candidates`` above :data:`MAX_CANDIDATES`, or data that would not fit in memory.

    References
    ----------
    T. Higo, Y. Matsushita, K. Ikeuchi, "Consensus photometric stereo", CVPR 2010.
    """
    count = check_count("candidates", candidates, MAX_CANDIDATES, minimum=16)
    if not 0 <= shadow_threshold < 1:
        raise ParameterError(f"shadow_threshold must be in [0, 1), got {shadow_threshold}")
    observations, lights, mask = _prepare(images, light_directions, mask)
    gray = _gray(observations)
    intensities = gray.T
    lit = (intensities > shadow_threshold * _reference(intensities)[:, None]).astype(float)
    ranks = _ranks(intensities)
    steps = 1 + len(_RINGS)
    lit, ranks = np.ascontiguousarray(lit), np.ascontiguousarray(ranks)
    normals, order = _global_search(ranks, lit, lights, _hemisphere(count))
    if callback is not None:
        callback(1, steps)
    from brdfkit.vision import _photometric_stereo_kernels

    cost = np.empty(len(normals))
    for step in range(len(_RINGS)):
        radius = _RINGS[step : step + 1]
        _photometric_stereo_kernels.consensus_rings(
            normals, cost, order, ranks, lit, lights, radius, step == 0
        )
        if callback is not None:
            callback(step + 2, steps)
    return _finish(normals, gray, lit, lights, observations, mask)


METHODS: dict[str, Callable[..., PhotometricStereoResult]] = {"consensus": consensus}
"""The consensus method by name (a ``--method`` choice of ``brdfkit ps``)."""
