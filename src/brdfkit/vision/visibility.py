r"""Visibility seen in the images: shadows observed under the fitted lights, carried to new ones.

A reflectance model fitted to photometric-stereo images (Lambertian, or the SVBRDF of
:mod:`brdfkit.vision.svbrdf`, fitted without the shadowed observations) predicts what a pixel
would show if every light reached it. Where the photograph under light ``l_k`` is much darker
than that prediction, something blocked the light (a cast shadow, e.g. a horse's far leg behind
its near one) or the model misses a darkening of its own. The observed visibility is

.. math::

    v_{kp} = \begin{cases} r_{kp} & r_{kp} < \tau \\ 1 & \text{otherwise} \end{cases},
    \qquad r_{kp} = \operatorname{clip}\!\Big(\frac{\bar I_{kp}}{\bar P_{kp}}, 0, 1\Big),

with ``I`` the image, ``P`` the prediction (``bar``: channel mean) and ``tau`` the ratio below
which an observation counts as shadowed (above it, the ratio is noise or misfit and the light is
taken to reach the pixel). It is known where the prediction is lit (``P`` above 2 % of its
99th percentile: not an attached shadow). Visibility is a function of the light direction per
pixel (Max's horizon map); for a new light ``l`` it is the Nadaraya-Watson kernel average over
the lights where it is known,

.. math::

    V_p(l) = \frac{\sum_k K(\angle(l, l_k))\, v_{kp}}{\sum_k K(\angle(l, l_k))}, \qquad
    K(\theta) = \exp\!\big(-\theta^2 / (2\sigma^2)\big),

and 1 where no light knows it. ``sigma`` (the angular width) and ``tau`` are chosen by
leave-one-light-out over the fitted images only (:func:`select_visibility`), never on a
held-out image. This is a measurement, not a shape: it needs no depth, and it sees the shadows
that an integrated depth (smoothed over its discontinuities) does not cast
(:func:`brdfkit.vision.svbrdf.shadow_visibility`). It can only be as good as the lights are
dense: a shadow seen under none of them is not predicted.

References
----------
.. [1] N. L. Max, "Horizon mapping: shadows for bump-mapped surfaces", The Visual Computer 4(2),
   109-117, 1988.
.. [2] E. A. Nadaraya, "On estimating regression", Theory Probab. Appl. 9(1), 141-142, 1964;
   G. S. Watson, "Smooth regression analysis", Sankhyā A 26(4), 359-372, 1964.
.. [3] T. Malzbender, D. Gelb, H. Wolters, "Polynomial texture maps", SIGGRAPH 2001 (per-pixel
   appearance as a function of the light direction, interpolated from photographs).
.. [4] M. Chandraker, S. Agarwal, D. Kriegman, "ShadowCuts: photometric stereo with shadows",
   CVPR 2007.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from brdfkit.errors import ParameterError
from brdfkit.vision.photometric_stereo import _prepare

WIDTHS = (2.5, 5.0, 10.0, 20.0, 40.0, math.inf)
"""Candidate angular widths ``sigma`` (degrees) of :func:`select_visibility`; infinity: the
mean over the lights (an ambient-occlusion-like constant per pixel)."""

RATIOS = (0.3, 0.5, 0.7)
"""Candidate shadow ratios ``tau`` of :func:`select_visibility`."""

LIT = 0.02
"""A prediction is lit (its visibility can be observed) above this fraction of its image's
99th percentile."""


def observed_visibility(
    predicted: ArrayLike, images: ArrayLike, light_directions: ArrayLike, mask: ArrayLike,
    *, ratio: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Visibility ``v`` (N, P) of the fitted lights at the mask's pixels, and where it is known.

    Parameters
    ----------
    predicted : (N, H, W, C) the model's images under the lights, without cast shadows.
    images : (N, H, W) or (N, H, W, C) the photographs the model was fitted to.
    light_directions : (N, 3) their lights.
    mask : (H, W) bool.
    ratio : ``tau`` in (0, 1]: an observation below this fraction of its prediction is shadowed.

    Returns
    -------
    (v, known): (N, P) float in [0, 1] and (N, P) bool, the pixels in ``mask`` order.
    """
    if not 0 < ratio <= 1:
        raise ParameterError(f"ratio must be in (0, 1], got {ratio}")
    observations, _, mask = _prepare(images, light_directions, mask)
    r, known = _ratios(_predicted_at(predicted, observations, mask), observations)
    return _thresholded(r, known, ratio), known


def _predicted_at(predicted: ArrayLike, observations: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The predictions ``(N, P, C)`` at the mask's pixels, checked against the images' shape."""
    predicted = np.asarray(predicted, dtype=np.float64)
    if predicted.shape[:3] != (len(observations), *mask.shape):
        raise ParameterError(
            f"predicted must have shape ({len(observations)}, {mask.shape[0]}, {mask.shape[1]}, C)"
            f" like the images; got {predicted.shape}"
        )
    return predicted[:, mask]


def _ratios(shading: np.ndarray, observations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``r`` (N, P) of the module formula, and where it is known (the prediction is lit)."""
    p = shading.mean(axis=-1)
    o = observations.mean(axis=-1)
    known = p > LIT * np.percentile(p, 99, axis=1, keepdims=True)
    return np.clip(o / np.where(known, p, 1.0), 0.0, 1.0), known


def _thresholded(r: np.ndarray, known: np.ndarray, ratio: float) -> np.ndarray:
    """``v``: the ratio where it is known and below ``ratio`` (shadowed), else 1."""
    return np.where(known & (r < ratio), r, 1.0)


def interpolate_visibility(
    visibility: np.ndarray, known: np.ndarray, light_directions: ArrayLike,
    new_directions: ArrayLike, *, width: float,
) -> np.ndarray:  # fmt: skip
    """Visibility ``(M, P)`` under ``new_directions`` (M, 3): the kernel average (module
    formula) of ``visibility`` (N, P) over the lights ``light_directions`` (N, 3) where it is
    ``known``, with angular width ``width`` degrees (> 0, infinity allowed); 1 where unknown."""
    if not width > 0:
        raise ParameterError(f"width must be a positive angle in degrees, got {width}")
    lights = np.asarray(light_directions, dtype=np.float64)
    new = np.atleast_2d(np.asarray(new_directions, dtype=np.float64))
    lights = lights / np.linalg.norm(lights, axis=1, keepdims=True)
    new = new / np.linalg.norm(new, axis=1, keepdims=True)
    angle = np.arccos(np.clip(new @ lights.T, -1.0, 1.0))  # (M, N)
    if math.isinf(width):
        kernel = np.ones_like(angle)
    else:
        # Relative to each new light's nearest: a narrow kernel far from every light stays finite.
        exponent = angle**2 / (2 * math.radians(width) ** 2)
        kernel = np.exp(-(exponent - exponent.min(axis=1, keepdims=True)))
    weight = known.astype(np.float64)
    total = kernel @ weight
    average = kernel @ (weight * visibility)
    return np.where(total > 1e-12, average / np.where(total > 1e-12, total, 1.0), 1.0)


def select_visibility(
    predicted: ArrayLike, images: ArrayLike, light_directions: ArrayLike, mask: ArrayLike,
    *, widths: tuple[float, ...] = WIDTHS, ratios: tuple[float, ...] = RATIOS,
) -> tuple[tuple[float, float] | None, dict[tuple[float, float] | None, float]]:  # fmt: skip
    """The ``(width, ratio)`` that best predicts each fitted image from the others' shadows.

    Leave one light out: for each light ``k`` the visibility observed under the other lights is
    interpolated to ``l_k`` and multiplies ``predicted[k]``; the score is the RMS error against
    ``images[k]`` over the mask and the channels, over all ``k``. ``None`` (no visibility)
    is a candidate too and wins where the observed shadows predict nothing. Only the given
    (fitted) images take part.

    Returns
    -------
    (best (width, ratio) or None, {candidate: RMS})
    """
    observations, lights, mask = _prepare(images, light_directions, mask)
    shading = _predicted_at(predicted, observations, mask)  # (N, P, C)
    return _select(shading, observations, lights, widths, ratios)


def _select(
    shading: np.ndarray, observations: np.ndarray, lights: np.ndarray,
    widths: tuple[float, ...], ratios: tuple[float, ...],
) -> tuple[tuple[float, float] | None, dict[tuple[float, float] | None, float]]:  # fmt: skip
    """:func:`select_visibility` on the mask's predictions and observations ``(N, P, C)``."""
    n = len(lights)
    if n < 2:
        raise ParameterError(f"select_visibility needs at least 2 lights, got {n}")
    scores: dict[tuple[float, float] | None, float] = {
        None: float(np.sqrt(np.mean((shading - observations) ** 2)))
    }
    r, known = _ratios(shading, observations)
    for ratio in ratios:
        v = _thresholded(r, known, ratio)
        for width in widths:
            squared = 0.0
            for k in range(n):
                others = np.arange(n) != k
                vk = interpolate_visibility(v[others], known[others], lights[others],
                                            lights[k], width=width)[0]  # fmt: skip
                squared += float(np.mean((shading[k] * vk[:, None] - observations[k]) ** 2))
            scores[(width, ratio)] = math.sqrt(squared / n)
    return min(scores, key=scores.get), scores


def relit_visibility(
    predicted: ArrayLike, images: ArrayLike, light_directions: ArrayLike, mask: ArrayLike,
    new_directions: ArrayLike, *, widths: tuple[float, ...] = WIDTHS,
    ratios: tuple[float, ...] = RATIOS,
) -> tuple[np.ndarray, tuple[float, float] | None]:  # fmt: skip
    """Visibility ``(M, H, W)`` of ``new_directions`` from the shadows seen in ``images``, with
    the width and ratio :func:`select_visibility` picks on those images (all 1 where it picks
    none), for ``relight(..., visibility=)``; returns it and the choice."""
    observations, lights, mask = _prepare(images, light_directions, mask)
    shading = _predicted_at(predicted, observations, mask)
    choice, _ = _select(shading, observations, lights, widths, ratios)
    new = np.atleast_2d(np.asarray(new_directions, dtype=np.float64))
    out = np.ones((len(new), *mask.shape))
    if choice is not None:
        width, ratio = choice
        r, known = _ratios(shading, observations)
        out[:, mask] = interpolate_visibility(
            _thresholded(r, known, ratio), known, lights, new, width=width
        )
    return out, choice
