r"""Camera response calibration by four methods behind one call, with the curve's uncertainty.

A camera maps the exposure :math:`X = E\,\Delta t` to a code :math:`Z = f(X)`; calibration
recovers the inverse response :math:`I = f^{-1}` on the codes 0…255 from a stack of exposures
of a static scene, up to one scale (here :math:`I(255) = 1`). Every method below uses the same
sampled pixels (:func:`~brdfkit.vision.calibration.sample_pixels`), codes 0 and 255 (clipped:
they bound the exposure, they do not measure it) only through the curve's ends, which are
extrapolated linearly from codes 1, 2 and 253, 254:

- ``"debevec"`` — Debevec & Malik (1997): :math:`\ln I` free at every code, least squares of
  :math:`\ln I(Z_{ij}) = \ln E_i + \ln\Delta t_j` with a smoothness penalty
  (:func:`~brdfkit.vision.calibration.recover_response`).
- ``"robertson"`` — Robertson, Borman & Stevenson (2003): maximum likelihood of
  :math:`I(Z_{ij}) = \Delta t_j E_i + N_{ij}` under Gaussian noise with the weights
  :math:`w(z) = \exp(-4(z - 127.5)^2/127.5^2)`, alternating
  :math:`E_i = \sum_j w_{ij}\Delta t_j I(Z_{ij}) / \sum_j w_{ij}\Delta t_j^2` and
  :math:`I(m) = \operatorname{mean}_{Z_{ij} = m}\,\Delta t_j E_i`.
- ``"mitsunaga_nayar"`` — Mitsunaga & Nayar (1999): a polynomial
  :math:`I(M) = \sum_{n=0}^{N} c_n M^n` of the normalised code :math:`M = Z/255` with
  :math:`I(1) = 1`, fitted to the ratios of consecutive exposures,
  :math:`\sum_{i,j} [I(M_{ij}) - R_{j} I(M_{i,j+1})]^2` with :math:`R_j = \Delta t_j / \Delta
  t_{j+1}`; the ratios then refined from the curve and the two alternated, the degree
  :math:`N \le 8` chosen by the error on half of the pixels held out. The paper refines
  :math:`R_j` as the mean over pixels of :math:`I(M_{ij}) / I(M_{i,j+1})`; here it is the least
  squares ratio :math:`\sum_i I(M_{ij}) I(M_{i,j+1}) / \sum_i I(M_{i,j+1})^2` (the mean of
  ratios of noisy dark codes is biased, and alternated with the curve it drifts away), and the
  refined ratios keep the span :math:`\sum_j \ln R_j` of the given times, which fixes the
  exponential ambiguity (:math:`I^\gamma` with :math:`R^\gamma` fits as well, Grossberg &
  Nayar 2003).
- ``"emor"`` — a low-dimensional prior in the manner of Grossberg & Nayar's empirical model of
  response (EMoR, 2004): :math:`I = h_0 + \sum_{k=1}^{K} c_k h_k` with the mean :math:`h_0` and
  the first :math:`K` principal components :math:`h_k` of a family of inverse responses, fitted
  by linear least squares to :math:`I(Z_{ij}) = \Delta t_j E_i` (the radiances eliminated,
  the scale fixed at code 128). The
  EMoR basis itself (from DoRF's 201 measured curves) is not distributed with any package, so
  the family here is parametric (:func:`response_family`: gamma, sRGB-like, filmic, log,
  Reinhard and polynomial curves), a stand-in built as EMoR was built, from curves rather than
  measurements.

The uncertainty is the bootstrap standard deviation of the curve (Efron & Tibshirani 1993):
the method rerun on the sampled pixels drawn again with replacement.

References
----------
.. [1] P. E. Debevec, J. Malik, "Recovering high dynamic range radiance maps from
       photographs", SIGGRAPH 1997.
.. [2] M. A. Robertson, S. Borman, R. L. Stevenson, "Estimation-theoretic approach to dynamic
       range enhancement using multiple exposures", J. Electronic Imaging 12(2), 219–228, 2003.
.. [3] T. Mitsunaga, S. K. Nayar, "Radiometric self calibration", CVPR 1999.
.. [4] M. D. Grossberg, S. K. Nayar, "Modeling the space of camera response functions",
       IEEE TPAMI 26(10), 1272–1282, 2004.
.. [5] M. D. Grossberg, S. K. Nayar, "Determining the camera response from images: what is
       knowable?", IEEE TPAMI 25(11), 1455–1467, 2003 (the exponential ambiguity).
.. [6] G. H. Golub, V. Pereyra, "The differentiation of pseudo-inverses and nonlinear least
       squares problems whose variables separate", SIAM J. Numer. Anal. 10(2), 1973.
.. [7] B. Efron, R. J. Tibshirani, *An Introduction to the Bootstrap*, Chapman & Hall, 1993.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import check_count
from brdfkit.errors import ParameterError
from brdfkit.params import check_choice
from brdfkit.vision.calibration import (
    LEVELS,
    _check_stack,
    _solve_channel,
    hat_weights,
    sample_pixels,
)

METHODS = ("debevec", "robertson", "mitsunaga_nayar", "emor")
"""The calibration methods of :func:`calibrate_response`."""

EMOR_COMPONENTS = 4
"""Principal components :math:`K` of the ``"emor"`` prior."""

MAX_DEGREE = 8
"""The highest polynomial degree ``"mitsunaga_nayar"`` tries."""

BOOTSTRAP = 8
"""Default bootstrap resamples of :func:`calibrate_response`."""

_CODES = np.arange(LEVELS) / (LEVELS - 1)
"""The normalised codes :math:`M = Z/255`."""


@dataclass(frozen=True, eq=False)
class ResponseCalibration:
    """A recovered inverse response.

    Attributes
    ----------
    method : the method (:data:`METHODS`).
    inverse : ``(256, C)`` the inverse response :math:`I(z) = f^{-1}(z)`, relative exposure,
        non-decreasing, :math:`I(255) = 1`.
    uncertainty : ``(256, C)`` the bootstrap standard deviation of ``inverse`` (zeros without
        resamples).
    samples : the pixels used.
    """

    method: str
    inverse: np.ndarray
    uncertainty: np.ndarray
    samples: int

    def log_inverse(self) -> np.ndarray:
        r""":math:`g = \ln I`, finite (a code of :math:`I = 0` takes half the least positive
        value): the response of :func:`~brdfkit.vision.calibration.merge_hdr`."""
        positive = np.where(self.inverse > 0, self.inverse, np.inf).min(axis=0)
        return np.log(np.maximum(self.inverse, 0.5 * positive))


# --------------------------------------------------------------------------- the family
def _gamma(x: np.ndarray, gamma: float) -> np.ndarray:
    return x ** (1 / gamma)


def _srgb_like(x: np.ndarray, exponent: float) -> np.ndarray:
    """IEC 61966-2-1's encoding with its exponent 2.4 replaced by ``exponent``."""
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / exponent) - 0.055)


def _aces(x: np.ndarray, exposure: float) -> np.ndarray:
    """Narkowicz's fit of the ACES filmic tone curve, exposure ``exposure``, 1 at x = 1."""

    def curve(v: np.ndarray) -> np.ndarray:
        return v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14)

    return curve(exposure * x) / curve(np.asarray(exposure))


def _log_curve(x: np.ndarray, a: float) -> np.ndarray:
    return np.log1p(a * x) / np.log1p(a)


def _reinhard(x: np.ndarray, exposure: float) -> np.ndarray:
    return (exposure * x / (1 + exposure * x)) * (1 + exposure) / exposure


def _polynomial(x: np.ndarray, a: float) -> np.ndarray:
    """:math:`x + a\\,x(1 - x)(1 + x)/2`, increasing for :math:`|a| \\le 1`."""
    return x + a * x * (1 - x) * (1 + x) / 2


_FAMILY: tuple[tuple[Callable[[np.ndarray, float], np.ndarray], np.ndarray], ...] = (
    (_gamma, np.geomspace(1.0, 3.2, 12)),
    (_srgb_like, np.linspace(1.8, 3.0, 7)),
    (_aces, np.geomspace(0.5, 8.0, 9)),
    (_log_curve, np.geomspace(0.5, 500.0, 10)),
    (_reinhard, np.geomspace(0.5, 20.0, 8)),
    (_polynomial, np.linspace(0.0, 1.0, 6)),
)
"""The parametric response curves :math:`f: [0, 1] \\to [0, 1]` of the ``"emor"`` prior and
their parameter values."""


def inverse_of(response: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """The inverse :math:`f^{-1}(z/255)` at the 256 codes of an increasing response
    :math:`f: [0, 1] \\to [0, 1]` with :math:`f(1) = 1` (interpolated on a dense grid).

    Examples
    --------
    >>> inverse = inverse_of(lambda x: x ** (1 / 2.2))
    >>> round(float(inverse[128]), 4) == round((128 / 255) ** 2.2, 4)
    True
    """
    x = np.concatenate([[0.0], np.geomspace(1e-7, 1.0, 20_000)])
    y = response(x)
    return np.interp(_CODES, y / y[-1], x)


def response_family() -> np.ndarray:
    """The inverse responses, ``(M, 256)``, of the parametric family behind the ``"emor"``
    prior: gamma curves (γ from 1 to 3.2), sRGB-like curves (exponent 1.8 to 3), the ACES
    filmic curve at exposures 0.5 to 8, log curves, Reinhard's tone curve and cubic
    polynomials; each normalised to :math:`I(0) = 0`, :math:`I(1) = 1`.

    Examples
    --------
    >>> family = response_family()
    >>> family.shape[1], bool(np.all(np.diff(family, axis=1) >= 0))
    (256, True)
    """
    curves = [
        inverse_of(functools.partial(curve, **{_parameter(curve): float(value)}))
        for curve, values in _FAMILY
        for value in values
    ]
    return np.array(curves)


def _parameter(curve: Callable[..., np.ndarray]) -> str:
    return curve.__code__.co_varnames[1]


@functools.cache
def emor_basis(components: int = EMOR_COMPONENTS) -> tuple[np.ndarray, np.ndarray]:
    """The mean :math:`h_0` ``(256,)`` and the first ``components`` principal components
    :math:`h_k` ``(components, 256)`` of :func:`response_family` (an SVD of the centred
    curves). Every :math:`h_k` is 0 at codes 0 and 255, so :math:`h_0 + \\sum c_k h_k` keeps
    :math:`I(0) = 0`, :math:`I(1) = 1`.

    Examples
    --------
    >>> mean, basis = emor_basis(4)
    >>> mean.shape, basis.shape, float(mean[-1]), float(abs(basis[:, -1]).max()) < 1e-12
    ((256,), (4, 256), 1.0, True)
    """
    family = response_family()
    mean = family.mean(axis=0)
    _, _, vt = np.linalg.svd(family - mean, full_matrices=False)
    return mean, vt[:components]


# --------------------------------------------------------------------------- the methods
def _extrapolated_ends(inverse: np.ndarray) -> np.ndarray:
    """``inverse`` with codes 0 and 255 extrapolated linearly from their two neighbours, made
    non-decreasing (a running maximum), non-negative and scaled to :math:`I(255) = 1`."""
    inverse = inverse.copy()
    inverse[0] = max(2 * inverse[1] - inverse[2], 0.0)
    inverse[-1] = 2 * inverse[-2] - inverse[-3]
    inverse = np.maximum.accumulate(np.maximum(inverse, 0.0))
    if not inverse[-1] > 0:
        raise ParameterError(
            "the exposures do not determine the camera response (the recovered curve is flat); "
            "use exposures that differ more, or sample more pixels"
        )
    return inverse / inverse[-1]


def _debevec(codes: np.ndarray, times: np.ndarray) -> np.ndarray:
    codes = codes[hat_weights(LEVELS)[codes].sum(axis=1) > 0]  # never well exposed: no equation
    g = _solve_channel(codes, np.log(times), 50.0, 0)
    return np.exp(g - g.max())


def _robertson(codes: np.ndarray, times: np.ndarray) -> np.ndarray:
    r"""Robertson et al.'s estimate, solved directly: their iteration alternates the two
    blocks of the normal equations of the weighted linear least squares
    :math:`\sum_{ij} w(Z_{ij})\,(I(Z_{ij}) - \Delta t_j E_i)^2` (block Gauss–Seidel, which
    crawls along the curve's overall bend: still moving after 1000 rounds), whose solution is
    taken here at once, with the gauge :math:`I(128) = 1` and a light penalty
    :data:`ROBERTSON_SMOOTHNESS` on :math:`I`'s second differences for codes seen rarely or
    never."""
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    z = np.arange(LEVELS)
    w = np.exp(-4 * (z - 127.5) ** 2 / 127.5**2)
    measured = (codes > 0) & (codes < LEVELS - 1)
    pixel, image = np.nonzero(measured)
    root = np.sqrt(w[codes[pixel, image]])
    rows = np.arange(pixel.size)
    count = codes.shape[0]
    data = sparse.csr_matrix(
        (
            np.concatenate([root, -root * times[image]]),
            (np.concatenate([rows, rows]), np.concatenate([codes[pixel, image], LEVELS + pixel])),
        ),
        shape=(pixel.size, LEVELS + count),
    )
    second = sparse.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(LEVELS - 2, LEVELS + count))
    gauge = sparse.csr_matrix(([1.0], ([0], [LEVELS // 2])), shape=(1, LEVELS + count))
    a = sparse.vstack([data, np.sqrt(ROBERTSON_SMOOTHNESS) * second, gauge]).tocsr()
    b = np.zeros(a.shape[0])
    b[-1] = 1.0
    ridge = sparse.identity(LEVELS + count) * 1e-12  # a pixel measured nowhere: E_i = 0
    return spsolve((a.T @ a + ridge).tocsc(), a.T @ b)[:LEVELS]


ROBERTSON_SMOOTHNESS = 1.0
r"""The weight :math:`\lambda` of the second differences of :math:`I` in ``"robertson"``
(:math:`I(128) = 1`)."""


def _polynomial_fit(pairs: tuple[np.ndarray, np.ndarray, np.ndarray], degree: int) -> np.ndarray:
    """The coefficients :math:`c_0 … c_N` of Mitsunaga–Nayar's least squares with
    :math:`\\sum c_n = 1` (:math:`c_N` eliminated), for code pairs ``(M_j, M_{j+1}, R_j)``."""
    low, high, ratio = pairs
    powers = np.arange(degree + 1)
    a = low[:, None] ** powers - ratio[:, None] * high[:, None] ** powers
    # c_N = 1 - Σ_{n<N} c_n: a[:, :N] c - a[:, N] Σ c + a[:, N] = 0
    reduced = a[:, :-1] - a[:, -1:]
    c, *_ = np.linalg.lstsq(reduced, -a[:, -1], rcond=None)
    return np.append(c, 1 - c.sum())


def _pairs(codes: np.ndarray, order: np.ndarray, ratios: np.ndarray) -> tuple[np.ndarray, ...]:
    """The normalised codes of consecutive exposures (shorter, longer) where both measure the
    exposure (codes 1…254), with the ratio of each pair's times."""
    lows, highs, rs = [], [], []
    for j in range(order.size - 1):
        low, high = codes[:, order[j]], codes[:, order[j + 1]]
        usable = (low > 0) & (low < LEVELS - 1) & (high > 0) & (high < LEVELS - 1)
        lows.append(_CODES[low[usable]])
        highs.append(_CODES[high[usable]])
        rs.append(np.full(int(usable.sum()), ratios[j]))
    return np.concatenate(lows), np.concatenate(highs), np.concatenate(rs)


def _mitsunaga_nayar(codes: np.ndarray, times: np.ndarray, rounds: int = 10) -> np.ndarray:
    order = np.argsort(times, kind="stable")
    ratios = times[order[:-1]] / times[order[1:]]
    half = np.arange(codes.shape[0]) % 2 == 0
    errors = {}
    for degree in range(1, MAX_DEGREE + 1):  # the degree by the held-out half's error
        c = _polynomial_fit(_pairs(codes[half], order, ratios), degree)
        low, high, r = _pairs(codes[~half], order, ratios)
        errors[degree] = np.mean((np.polyval(c[::-1], low) - r * np.polyval(c[::-1], high)) ** 2)
    degree = min(errors, key=errors.__getitem__)
    for _ in range(rounds):  # the ratios refined from the curve, and the curve from them
        c = _polynomial_fit(_pairs(codes, order, ratios), degree)
        ratios = _refined_ratios(codes, order, ratios, c)
    return np.polyval(_polynomial_fit(_pairs(codes, order, ratios), degree)[::-1], _CODES)


def _refined_ratios(
    codes: np.ndarray, order: np.ndarray, ratios: np.ndarray, c: np.ndarray
) -> np.ndarray:
    """The least-squares ratios :math:`R_j` of :math:`I(M_{ij}) \\approx R_j I(M_{i,j+1})` over
    the pixels that both exposures measure (the old ratio where none does), scaled to the span
    of ``ratios`` (module docstring)."""
    inverse = np.polyval(c[::-1], _CODES)
    refined = ratios.copy()
    for j in range(order.size - 1):
        low, high = codes[:, order[j]], codes[:, order[j + 1]]
        usable = (low > 0) & (low < LEVELS - 1) & (high > 0) & (high < LEVELS - 1)
        usable &= (inverse[high] > 0) & (inverse[low] > 0)
        if usable.any():
            shorter, longer = inverse[low[usable]], inverse[high[usable]]
            refined[j] = float(shorter @ longer / (longer @ longer))
    return np.exp(np.log(refined) * (np.log(ratios).sum() / np.log(refined).sum()))


def _emor(codes: np.ndarray, times: np.ndarray) -> np.ndarray:
    r"""Least squares of :math:`I(Z_{ij}) - \Delta t_j E_i` over the measuring codes (1…254)
    for :math:`I = a h_0 + \sum_k c_k h_k` with the gauge :math:`I(128) = 1` (which gives
    :math:`a`), each :math:`E_i` eliminated (projected out per pixel: variable projection,
    Golub & Pereyra 1973).

    The gauge sits at a measured code: pinned only at the unmeasured code 255, a curve near 0
    over every measured code (then rising to 1) makes every equation nearly 0, a trivial
    solution that few samples do not rule out. The equations count alike: weights that depend
    on the observed code (Debevec & Malik's hat) correlate with its noise and bias the curve
    (by about 1.5 % of its range at a full well of 10⁴ electrons)."""
    mean, basis = emor_basis(EMOR_COMPONENTS)
    gauge = LEVELS // 2
    mean = mean / mean[gauge]
    basis = basis - np.outer(basis[:, gauge], mean)  # each 0 at the gauge
    measured = ((codes > 0) & (codes < LEVELS - 1)).astype(np.float64)  # (N, P)
    a = basis.T[codes] * measured[..., None]  # (N, P, K)
    b = mean[codes] * measured
    t = measured * times  # the column of E_i, per pixel
    norm = np.maximum((t * t).sum(axis=1), 1e-300)
    a = a - t[..., None] * (np.einsum("np,npk->nk", t, a) / norm[:, None])[:, None, :]
    b = b - t * ((t * b).sum(axis=1) / norm)[:, None]
    c, *_ = np.linalg.lstsq(a.reshape(-1, basis.shape[0]), -b.ravel(), rcond=None)
    return mean + c @ basis


_SOLVERS: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "debevec": _debevec,
    "robertson": _robertson,
    "mitsunaga_nayar": _mitsunaga_nayar,
    "emor": _emor,
}


def _channel_inverse(method: str, codes: np.ndarray, times: np.ndarray) -> np.ndarray:
    """One channel's inverse response from its ``(N, P)`` sampled codes."""
    return _extrapolated_ends(_SOLVERS[method](codes, times))


def calibrate_response(
    images: Sequence[ArrayLike] | np.ndarray,
    exposure_times: ArrayLike,
    method: str = "emor",
    *,
    samples: int = 1000,
    bootstrap: int = BOOTSTRAP,
    seed: int = 0,
) -> ResponseCalibration:
    """The inverse camera response of an exposure stack and its uncertainty (module docstring).

    Parameters
    ----------
    images : (P, H, W) or (P, H, W, C) uint8 exposures of a static scene.
    exposure_times : (P,) in seconds, finite, positive; equal times only for equal images.
    method : one of :data:`METHODS` (default ``"emor"``, the least error on
        ``benchmarks/bench_hdr.py``'s simulated stacks).
    samples : pixels sampled (:func:`~brdfkit.vision.calibration.sample_pixels`), 2 … 10⁵.
    bootstrap : resamples for the uncertainty, 0 … 1000 (0: none, zeros).
    seed : of the sampling and the resamples.

    Returns
    -------
    ResponseCalibration

    Raises
    ------
    brdfkit.errors.ParameterError
        A bad stack or times, an unknown method, or exposures that do not determine the curve.

    References
    ----------
    .. [1] P. E. Debevec, J. Malik, SIGGRAPH 1997. .. [2] M. A. Robertson et al., JEI 2003.
    .. [3] T. Mitsunaga, S. K. Nayar, CVPR 1999. .. [4] M. D. Grossberg, S. K. Nayar, TPAMI 2004.

    Examples
    --------
    A gamma-2.2 camera, five exposures of a ramp of radiances:

    >>> import numpy as np
    >>> radiance = np.geomspace(0.01, 1.0, 4096).reshape(64, 64)
    >>> times = np.array([0.25, 0.5, 1.0, 2.0, 4.0])
    >>> codes = [np.round(255 * np.clip(radiance * t, 0, 1) ** (1 / 2.2)).astype(np.uint8)
    ...          for t in times]
    >>> result = calibrate_response(codes, times, "mitsunaga_nayar", bootstrap=2)
    >>> truth = (np.arange(256) / 255) ** 2.2
    >>> bool(np.abs(result.inverse[:, 0] - truth).max() < 0.01), result.inverse.shape
    (True, (256, 1))
    """
    check_choice("method", method, METHODS)
    stack, times = _check_stack(images, exposure_times)
    bootstrap = check_count("bootstrap", bootstrap, 1000, minimum=0)
    pixels = sample_pixels(stack, samples, seed)
    rng = np.random.default_rng(seed)
    draws = [rng.integers(0, pixels.size, pixels.size) for _ in range(bootstrap)]
    inverse, spread = [], []
    for channel in range(stack.shape[-1]):
        codes = stack[..., channel].reshape(stack.shape[0], -1)[:, pixels].T  # (N, P)
        inverse.append(_channel_inverse(method, codes, times))
        resampled = [_channel_inverse(method, codes[draw], times) for draw in draws]
        spread.append(np.std(resampled, axis=0) if resampled else np.zeros(LEVELS))
    return ResponseCalibration(
        method, np.stack(inverse, axis=-1), np.stack(spread, axis=-1), int(pixels.size)
    )


__all__ = [
    "BOOTSTRAP",
    "EMOR_COMPONENTS",
    "MAX_DEGREE",
    "METHODS",
    "ResponseCalibration",
    "calibrate_response",
    "emor_basis",
    "inverse_of",
    "response_family",
]
