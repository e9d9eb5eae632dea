"""Progressive rendering: passes of growing sample counts, each with its noise estimate.

:func:`progressive` yields a :class:`Pass` per refinement (the running mean, its per-pixel
standard error and, with Sobol' replicates, an unbiased error estimate), so that a viewer can
show an image at once and refine it, and stop when the noise is low enough.

References
----------
.. [1] A. B. Owen, *Monte Carlo theory, methods and examples*, 2013, §17.2 (independent
       replicates of randomized quasi-Monte Carlo).
.. [2] T. F. Chan, G. H. Golub, R. J. LeVeque, "Updating formulae and a pairwise algorithm for
       computing sample variances", COMPSTAT 1982.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.light.base import Light
from brdfkit.render.scene import Camera, GBuffer, Sphere, gbuffer
from brdfkit.render.shading import _SHADE_DEFAULTS, _SHADE_OPTIONS, _shade


# --------------------------------------------------------------------------- progressive
@dataclass(frozen=True, eq=False)
class Pass:
    """One refinement of :func:`progressive`: the running mean ``image`` ``(H, W, C)``, its
    per-pixel standard error ``stderr`` (same shape: from the samples' spread, conservative
    with Sobol' points), the total samples per pixel so far, the seconds elapsed since
    rendering began and, with Sobol' replicates, ``error`` (same shape): half the difference
    of the two replicates, whose square estimates each pixel's variance without bias."""

    image: np.ndarray
    stderr: np.ndarray
    samples: int
    seconds: float
    error: np.ndarray | None = None


class _Cancelled(Exception):
    """Raised between tiles when :func:`progressive`'s ``cancel`` is set."""


def progressive(
    g: GBuffer,
    brdf: BRDF,
    lights: Light | Sequence[Light],
    *,
    max_samples: int = 1024,
    first_samples: int = 1,
    seed: int = 0,
    cancel: threading.Event | None = None,
    **shade_kwargs: Any,
) -> Iterator[Pass]:
    r"""Render the G-buffer in passes of doubling sample counts, yielding the running mean.

    The first pass shades ``first_samples`` samples per pixel (an image in a fraction of a
    full render's time); each later pass shades as many samples as all passes before it, so
    the total doubles until ``max_samples`` (with Sobol' replicates, from
    :data:`HALF_STEPS_FROM` samples of each on, half as many: totals 64, 96, 128, 192, …,
    a finer choice of when to stop). Each pass is :func:`shade` work
    (``shade_kwargs``: ``method``, ``sequence``, ``compiled``, …). With ``compiled=True``
    (default) kernels not built yet are built on a background thread while the first passes
    run on NumPy, and used from the next pass once they are ready (built kernels: from the
    first pass). Setting ``cancel`` stops
    rendering between tiles: the pass under way is dropped and the iterator ends.

    With ``sequence="sobol"`` (default) a pixel's samples are two independent replicates,
    each one scrambled Sobol' sequence per pixel that every pass continues
    (``first_sample``: after N samples of each, the next N), so that after each pass each
    replicate holds a whole scrambled net, not a union of independently scrambled pieces
    (whose error is higher for the same samples). The first pass
    has ``first_samples`` samples in all (half from each; at least one each), and
    ``max_samples`` counts both. :attr:`Pass.error` is :math:`|\bar x_A - \bar x_B|/2`:
    its square is an unbiased estimate of the image's variance
    :math:`\operatorname{Var}((\bar x_A + \bar x_B)/2)` per pixel (noisy per pixel, exact
    on average: Owen's independent replicates of randomized quasi-Monte Carlo). With
    ``"random"`` passes are independent draws. Either way all samples are pooled by the
    exact mean and sum of squared deviations (Chan et al.), and ``stderr`` is
    :math:`\sqrt{M_2}/N` over all N samples (0 after a single sample: no estimate yet; a
    conservative over-estimate with Sobol' points).

    References
    ----------
    .. [1] T. F. Chan, G. H. Golub, R. J. LeVeque, "Updating formulae and a pairwise
           algorithm for computing sample variances", COMPSTAT 1982.
    .. [2] A. B. Owen, *Monte Carlo theory, methods and examples*, 2013, §17.2 (independent
           replicates of randomized quasi-Monte Carlo estimate its variance).

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> from brdfkit.light import DirectionalLight
    >>> from brdfkit.render import Sphere, gbuffer
    >>> g = gbuffer(Sphere(), resolution=4)
    >>> model, light = parse("ggx(alpha=0.3)"), DirectionalLight((1.0, 0.0, 1.0))
    >>> passes = list(progressive(g, model, light, max_samples=8, compiled=False))
    >>> [p.samples for p in passes], passes[-1].image.shape
    ([2, 4, 8], (4, 4, 1))
    """
    if first_samples < 1:
        raise ValueError(f"first_samples must be >= 1; got {first_samples}")
    if max_samples < first_samples:
        raise ValueError(
            f"max_samples must be >= first_samples ({first_samples}); got {max_samples}"
        )
    unknown = set(shade_kwargs) - _SHADE_OPTIONS
    if unknown:
        raise TypeError(f"progressive() got unexpected keyword arguments {sorted(unknown)}")
    user_progress = shade_kwargs.pop("progress", None)

    def between_tiles(done: int, total: int) -> None:
        if cancel is not None and cancel.is_set():
            raise _Cancelled
        if user_progress is not None:
            user_progress(done, total)

    kwargs = {**_SHADE_DEFAULTS, **shade_kwargs}
    # with shadows (``visibility``) no kernels are built in the background: the passes take
    # the compiled path where its kernels are built already
    compiles = kwargs["compiled"] is True and kwargs["visibility"] is None
    builder = _background_build(brdf, lights, kwargs) if compiles else None

    cache: dict[Any, Any] = {}  # the plan and each tile's sample-independent work

    def shade_pass(samples: int, pass_seed: int, first_sample: int) -> tuple[Any, Any]:
        nonlocal builder
        if builder is not None and not builder.is_alive():
            # the kernels are ready (or do not apply: NumPy from now on)
            kwargs["compiled"], builder = builder.built, None  # type: ignore[attr-defined]
        return _shade(
            g, brdf, lights, **kwargs, samples=samples, seed=pass_seed,
            progress=between_tiles, first_sample=first_sample, cache=cache,
        )  # fmt: skip

    start = time.perf_counter()
    passes = _replicate_passes if kwargs["sequence"] == "sobol" else _pooled_passes
    try:
        for image, stderr, count, error in passes(
            shade_pass, seed, first_samples, max_samples, cancel
        ):
            yield Pass(image, stderr, count, time.perf_counter() - start, error)
    except _Cancelled:
        return


def _pool(
    pooled: tuple[np.ndarray, np.ndarray, int] | None, value: np.ndarray, stderr: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """(mean, M2, count) of the samples pooled so far and the ``n`` of a new shade (its mean
    and standard error), by Chan et al.'s update."""
    pass_m2 = stderr * stderr * (n * n)
    if pooled is None:
        return value, pass_m2, n
    mean, m2, count = pooled
    delta = value - mean
    total = count + n
    return mean + delta * (n / total), m2 + pass_m2 + delta * delta * (count * n / total), total


def _pooled_passes(
    shade_pass: Callable[..., tuple[Any, Any]],
    seed: int,
    first_samples: int,
    max_samples: int,
    cancel: threading.Event | None,
) -> Iterator[tuple[np.ndarray, np.ndarray, int, None]]:
    """:func:`progressive`'s passes of independent draws, pooled (``sequence="random"``)."""
    pooled, count, index = None, 0, 0
    while count < max_samples:
        if cancel is not None and cancel.is_set():
            return
        n = min(first_samples if count == 0 else count, max_samples - count)
        value, stderr = shade_pass(n, seed if index == 0 else _pass_seed(seed, index), 0)
        pooled = _pool(pooled, value, stderr, n)
        mean, m2, count = pooled
        index += 1
        yield mean.copy(), np.sqrt(m2) / count, count, None


HALF_STEPS_FROM = 32
"""Samples of each Sobol' replicate from which :func:`progressive`'s passes grow by half
(totals 64, 96, 128, 192, 256, …: each pass still an aligned block of the sequences)."""


def _replicate_passes(
    shade_pass: Callable[..., tuple[Any, Any]],
    seed: int,
    first_samples: int,
    max_samples: int,
    cancel: threading.Event | None,
) -> Iterator[tuple[np.ndarray, np.ndarray, int, np.ndarray]]:
    """:func:`progressive`'s passes continuing two independent replicates' sequences."""
    seeds = (seed, _pass_seed(seed, 1))
    means: list[Any] = [None, None]  # each replicate's mean
    pooled = None  # both replicates' samples, pooled
    count = 0  # samples of each replicate so far
    while 2 * count < max_samples:
        if cancel is not None and cancel.is_set():
            return
        if count == 0:
            n = max(1, first_samples // 2)
        elif count < HALF_STEPS_FROM:
            n = count
        else:  # half the largest power of two in count: an aligned block of the sequence
            n = 1 << (count.bit_length() - 2)
        n = min(n, -(-(max_samples - 2 * count) // 2))
        for r, replicate_seed in enumerate(seeds):
            value, stderr = shade_pass(n, replicate_seed, count)
            previous = means[r]
            means[r] = (
                value if previous is None else previous + (value - previous) * (n / (count + n))
            )
            pooled = _pool(pooled, value, stderr, n)
        count += n
        a, b = means
        yield (a + b) / 2, np.sqrt(pooled[1]) / (2 * count), 2 * count, np.abs(a - b) / 2


def _background_build(
    brdf: BRDF, lights: Light | Sequence[Light], kwargs: dict[str, Any]
) -> threading.Thread | None:
    """A thread building the compiled shader while the first passes run on NumPy
    (``kwargs["compiled"]`` ``False`` meanwhile), or ``None`` where it is built already."""
    from brdfkit.render.compiled_shading import compiled_shader

    light_list = [lights] if isinstance(lights, Light) else list(lights)
    method = kwargs["method"]
    if compiled_shader(brdf, light_list, method=method, build=False) is not None:
        return None
    kwargs["compiled"] = False

    def build() -> None:
        plan = compiled_shader(brdf, light_list, method=method)
        if plan is not None:
            plan[0].build()
            thread.built = True  # type: ignore[attr-defined]

    thread = threading.Thread(target=build, name="brdfkit-compile", daemon=True)
    thread.built = False  # type: ignore[attr-defined]
    thread.start()
    return thread


def progressive_sphere(
    brdf: BRDF,
    lights: Light | Sequence[Light],
    resolution: int = 256,
    camera: Camera | None = None,
    **kwargs: Any,
) -> Iterator[Pass]:
    """:func:`progressive` on a unit sphere seen by ``camera`` (as :func:`render_sphere`).

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.light import UniformSky
    >>> for step in progressive_sphere(Lambertian(rho=0.5), UniformSky(), 4, max_samples=4):
    ...     print(step.samples, step.image.shape, step.error is not None)
    2 (4, 4, 1) True
    4 (4, 4, 1) True
    """
    return progressive(gbuffer(Sphere(), camera, resolution), brdf, lights, **kwargs)


def _pass_seed(seed: int, index: int) -> int:
    """An independent seed per pass (tiles add their first row to it)."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint64)[0] >> 2)


__all__ = [
    "Pass",
    "progressive",
    "progressive_sphere",
]
