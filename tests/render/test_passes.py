"""Progressive rendering: passes add up to a one-shot render, their error shrinks, cancel stops."""

from __future__ import annotations

import itertools
import threading

import numpy as np
import pytest

from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.light import EnvironmentMap
from brdfkit.render import Pass, Sphere, gbuffer, progressive, progressive_sphere, shade
from brdfkit.render.compiled_shading import kernels_built
from brdfkit.render.passes import _pass_seed
from brdfkit.render.reflection_equation import FLOOR_DIRECTIONS

GOLD = RoughConductor(alpha=0.3, material="Au", masking="smith_separable")
BRDF = Lambertian([0.2, 0.3, 0.1]) + GOLD
NUMPY = {"compiled": False}  # these tests check the passes, not the kernels: no compiling


def _map() -> EnvironmentMap:
    return EnvironmentMap(np.random.default_rng(1).random((16, 32, 3)) ** 3 * 4)


def test_passes_double_and_the_first_is_a_one_sample_render():
    g = gbuffer(Sphere(), None, 12)
    env = _map()
    random = {"sequence": "random", **NUMPY}
    passes = list(progressive(g, BRDF, env, max_samples=20, seed=3, **random))
    assert all(isinstance(p, Pass) for p in passes)
    assert [p.samples for p in passes] == [1, 2, 4, 8, 16, 20]
    assert all(b.seconds >= a.seconds for a, b in itertools.pairwise(passes))
    first = shade(g, BRDF, env, samples=1, seed=3, **random)
    np.testing.assert_array_equal(passes[0].image, first)
    assert passes[-1].image.shape == (12, 12, 3) == passes[-1].stderr.shape
    assert np.all(passes[-1].image[~g.mask] == 0) and np.all(passes[-1].stderr[~g.mask] == 0)
    assert passes[-1].error is None


def test_sobol_passes_continue_two_replicate_sequences():
    """After each pass each replicate is the first N points of its pixels' sequences: the
    image is the mean of two one-shot renders of N samples, ``error`` half their difference."""
    g = gbuffer(Sphere(), None, 12)
    env = _map()
    passes = list(progressive(g, GOLD, env, max_samples=32, seed=3, **NUMPY))
    assert [p.samples for p in passes] == [2, 4, 8, 16, 32]
    for p in (passes[0], passes[-1]):
        a = shade(g, GOLD, env, samples=p.samples // 2, seed=3, **NUMPY)
        b = shade(g, GOLD, env, samples=p.samples // 2, seed=_pass_seed(3, 1), **NUMPY)
        np.testing.assert_allclose(p.image, (a + b) / 2, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(p.error, np.abs(a - b) / 2, rtol=1e-9, atol=1e-15)
    assert np.all(passes[-1].stderr[g.mask] > 0)
    counts = [p.samples for p in progressive(g, GOLD, env, max_samples=256, **NUMPY)]
    assert counts == [2, 4, 8, 16, 32, 64, 96, 128, 192, 256]  # by half from 64 on


def test_accumulated_image_equals_a_one_shot_render_within_monte_carlo_error():
    g = gbuffer(Sphere(), None, 24)
    env = _map()
    *_, last = progressive(g, GOLD, env, max_samples=64, seed=1, sequence="random", **NUMPY)
    one_shot = shade(g, GOLD, env, samples=64, seed=99, sequence="random", **NUMPY)
    # the one-shot render's own standard error, from the same estimator
    (reference,) = progressive(g, GOLD, env, max_samples=64, first_samples=64, seed=99,
                               sequence="random", **NUMPY)  # fmt: skip
    np.testing.assert_array_equal(reference.image, one_shot)
    m = g.mask
    z = (last.image - one_shot)[m] / np.hypot(last.stderr, reference.stderr)[m]
    assert abs(np.mean(z)) < 0.1, np.mean(z)
    assert 0.8 < np.std(z) < 1.2, np.std(z)
    assert np.mean(np.abs(z) > 4) < 0.003


def test_stderr_shrinks_as_one_over_root_samples():
    g = gbuffer(Sphere(), None, 16)
    passes = {
        p.samples: p
        for p in progressive(
            g, GOLD, _map(), max_samples=256, first_samples=4, sequence="random", **NUMPY
        )
    }
    m = g.mask
    ratio = np.median(passes[16].stderr[m]) / np.median(passes[256].stderr[m])
    assert 3.4 < ratio < 4.6, ratio  # sqrt(256 / 16) = 4
    # and the pooled estimate is honest: the 16-sample image (the first samples of the
    # 256-sample one) differs from it by σ·√(1/16 − 1/256) = stderr₂₅₆·√15
    z = (passes[16].image - passes[256].image)[m] / (passes[256].stderr[m] * np.sqrt(15))
    assert 0.85 < np.std(z) < 1.15, np.std(z)


def test_cancel_before_during_and_between_passes():
    g = gbuffer(Sphere(), None, 16)
    env = _map()
    cancel = threading.Event()
    cancel.set()
    assert list(progressive(g, GOLD, env, cancel=cancel, **NUMPY)) == []

    cancel = threading.Event()
    iterator = progressive(g, GOLD, env, max_samples=1024, cancel=cancel, **NUMPY)
    first = next(iterator)
    assert first.samples == 2  # one sample of each Sobol' replicate
    cancel.set()
    assert list(iterator) == []

    # set while a pass is under way (after its first tile): that pass is dropped
    cancel = threading.Event()
    tiles: list[int] = []

    def progress(done: int, total: int) -> None:
        tiles.append(done)
        if len(tiles) == 3:
            cancel.set()

    passes = list(
        progressive(
            g,
            GOLD,
            env,
            max_samples=1024,
            cancel=cancel,
            progress=progress,
            max_evaluations=(2 + FLOOR_DIRECTIONS) * 16 * 6,  # 1 spp: tiles of 6 rows
            sequence="random",
            **NUMPY,
        )
    )
    assert [p.samples for p in passes] == [1]  # its 3 tiles fill the first pass
    assert len(tiles) == 3


def test_progressive_sphere_and_argument_errors():
    (only,) = progressive_sphere(
        BRDF, _map(), resolution=8, max_samples=4, first_samples=4, **NUMPY
    )
    assert only.samples == 4 and only.image.shape == (8, 8, 3)
    with pytest.raises(ValueError, match="first_samples"):
        next(progressive_sphere(BRDF, _map(), resolution=8, first_samples=0))
    with pytest.raises(ValueError, match="max_samples"):
        next(progressive_sphere(BRDF, _map(), resolution=8, max_samples=2, first_samples=4))
    with pytest.raises(TypeError, match="samples"):
        next(progressive_sphere(BRDF, _map(), resolution=8, samples=4))


@pytest.mark.slow
def test_auto_builds_the_kernels_in_the_background_and_switches_to_them():
    model = RoughConductor(alpha=0.45, material="Ag", masking="smith_separable")
    g = gbuffer(Sphere(), None, 8)
    assert not kernels_built(model)
    passes = []
    for p in progressive(g, model, _map(), max_samples=1 << 16, first_samples=16):
        passes.append(p)
        if kernels_built(model) and len(passes) > 1:
            break
    assert kernels_built(model)
    *_, last = progressive(g, model, _map(), max_samples=32, first_samples=32)
    a = shade(g, model, _map(), samples=16, seed=0, compiled=True)
    b = shade(g, model, _map(), samples=16, seed=_pass_seed(0, 1), compiled=True)
    np.testing.assert_array_equal(last.image, (a + b) / 2)  # built: used from the first pass
