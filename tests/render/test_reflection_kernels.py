"""The compiled environment-map shader equals the NumPy path and passes a furnace test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit import sampling
from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.light import DirectionalLight, EnvironmentMap, PointLight, SphereLight
from brdfkit.render import (
    Sphere,
    directional_albedo,
    gbuffer,
    reflected_radiance,
    render_sphere,
    shade,
)
from brdfkit.render.compiled_shading import (
    BUILD_SECONDS,
    EnvironmentShader,
    build_estimate,
    build_kernels,
    compiled_shader,
    kernels_built,
    pending_kernels,
)
from brdfkit.render.compiled_shading import reflected_radiance as compiled_radiance

GOLD = RoughConductor(alpha=0.2, material="Au", masking="smith_separable")


def _map(seed: int = 1, rotation: np.ndarray | None = None) -> EnvironmentMap:
    """A small map with bright texels (a peaked distribution) and dark ones."""
    image = np.random.default_rng(seed).random((16, 32, 3)) ** 4 * 5
    return EnvironmentMap(image, scale=1.5, rotation=rotation)


def _rotation() -> np.ndarray:
    a, b = 0.7, -0.4
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    return rz @ rx


@pytest.mark.parametrize("brdf", [GOLD, Lambertian([0.3, 0.2, 0.1]) + GOLD])
def test_shade_compiled_float64_equals_numpy_path_on_a_sphere(brdf):
    g = gbuffer(Sphere(), None, 16)
    env = _map()
    expected = shade(g, brdf, env, samples=16, seed=5, max_evaluations=2_000, compiled=False)
    image = shade(g, brdf, env, samples=16, seed=5, max_evaluations=2_000, compiled="float64")
    assert np.all(image[~g.mask] == 0)
    np.testing.assert_allclose(image, expected, rtol=1e-11, atol=1e-13)


def test_shade_compiled_float32_equals_numpy_path_to_float32_precision():
    g = gbuffer(Sphere(), None, 16)
    env = _map()
    expected = shade(g, GOLD, env, samples=16, seed=2, compiled=False)
    image = shade(g, GOLD, env, samples=16, seed=2)  # the default: float32 kernels
    scale = np.max(expected)
    assert np.max(np.abs(image - expected)) < 1e-3 * scale
    assert np.median(np.abs(image - expected)[g.mask]) < 1e-5 * scale


@pytest.mark.parametrize("heuristic", ["power", "balance"])
def test_random_uniforms_rotated_map_and_stderr_equal_numpy_path(heuristic):
    g = gbuffer(Sphere(), None, 8)
    env = _map(3, _rotation())
    args = (GOLD, env, g.wo, g.normals, g.points, g.tangents)
    kwargs = {"samples": 12, "seed": 9, "sequence": "random", "heuristic": heuristic}
    expected = reflected_radiance(*args, method="mis", **kwargs)
    estimate = compiled_radiance(*args, method="mis", dtype=np.float64, **kwargs)
    np.testing.assert_allclose(estimate.value, expected.value, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(estimate.stderr, expected.stderr, rtol=1e-9, atol=1e-13)


def test_sobol_blocks_and_per_pixel_seeds_equal_numpy_path():
    """The kernel scrambles the Sobol' digits per pixel as sampling.scrambled_sobol does."""
    from brdfkit.sampling import query_seeds

    g = gbuffer(Sphere(), None, 8)
    env = _map(3, _rotation())
    args = (GOLD, env, g.wo, g.normals, g.points, g.tangents)
    seeds = query_seeds(21, 64).reshape(8, 8)
    kwargs = {"samples": 8, "seed": seeds, "sequence": "sobol", "first_sample": 8}
    expected = reflected_radiance(*args, **kwargs)
    estimate = compiled_radiance(*args, dtype=np.float64, **kwargs)
    np.testing.assert_allclose(estimate.value, expected.value, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(estimate.stderr, expected.stderr, rtol=1e-9, atol=1e-13)


def test_scrambled_sobol_estimates_are_unbiased_in_a_furnace():
    """Independent seeds of the per-pixel scrambled sequences average to L·ρ(wo) (ρ by
    quadrature), within their own spread across seeds."""
    radiance = 0.8
    env = EnvironmentMap(np.full((8, 16, 3), radiance))
    theta = np.linspace(0.05, 1.45, 8)
    wo = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    albedo = directional_albedo(GOLD, wo, method="quadrature", theta_steps=128, phi_steps=256)
    shader = EnvironmentShader(GOLD, env, method="mis", dtype=np.float64)
    values = np.stack([shader(wo, samples=16, seed=s, sequence="sobol").value for s in range(16)])
    z = (values.mean(axis=0) - radiance * albedo.value) / (values.std(axis=0, ddof=1) / 4)
    assert np.all(np.abs(z) < 5), z


def test_constant_map_furnace_gives_radiance_times_directional_albedo():
    """Under a constant map L the reflected radiance is L·ρ(wo) (ρ by quadrature)."""
    radiance = 0.8
    env = EnvironmentMap(np.full((8, 16, 3), radiance))
    theta = np.linspace(0.05, 1.45, 8)
    wo = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    albedo = directional_albedo(GOLD, wo, method="quadrature", theta_steps=128, phi_steps=256)
    estimate = EnvironmentShader(GOLD, env, dtype=np.float64)(wo, samples=4096, seed=4)
    z = (estimate.value - radiance * albedo.value) / estimate.stderr
    assert np.all(np.abs(z) < 5), z
    # a Lambertian lobe alone needs no samples: ρ·L exactly
    white = EnvironmentShader(Lambertian([0.5, 0.7, 0.9]), env, dtype=np.float64)(wo)
    expected = np.broadcast_to(radiance * np.array([0.5, 0.7, 0.9]), white.value.shape)
    np.testing.assert_allclose(white.value, expected, rtol=1e-5)
    assert np.all(white.stderr == 0)


def test_mask_skips_pixels_without_changing_the_others():
    g = gbuffer(Sphere(), None, 8)
    shader = EnvironmentShader(GOLD, _map(), dtype=np.float64)
    full = shader(g.wo, g.normals, g.points, g.tangents, samples=8, sequence="sobol")
    masked = shader(g.wo, g.normals, g.points, g.tangents, samples=8, sequence="sobol", mask=g.mask)
    # To rounding: with the parameters an input of the kernels (not folded constants), a
    # pixel's place in a vectorised block (main loop or remainder) can change its last bit.
    np.testing.assert_allclose(masked.value[g.mask], full.value[g.mask], rtol=1e-15, atol=0)
    assert np.all(masked.value[~g.mask] == 0)


def test_the_floor_in_batches_equals_the_numpy_floor():
    """The control variate's k (the median of f over the floor's fixed directions), taken
    in batches that the kernel runs on the calling thread, equals the NumPy path's
    :func:`~brdfkit.render.diffuse_floor` on every pixel, across the batches' bounds."""
    from brdfkit.render import diffuse_floor

    shader = EnvironmentShader(GOLD, _map(), dtype=np.float64)
    wo = sampling.square_to_uniform_hemisphere(np.random.default_rng(5).random((5000, 2)))
    np.testing.assert_allclose(shader._floor(wo), diffuse_floor(shader.rest, wo), rtol=1e-12)


def test_unsupported_inputs_are_refused():
    env = _map()
    with pytest.raises(ValueError, match="one EnvironmentMap"):
        EnvironmentShader(GOLD, DirectionalLight((0, 0, 1), 1.0))
    with pytest.raises(ValueError, match="one EnvironmentMap"):
        EnvironmentShader(GOLD, [env, env])
    with pytest.raises(ValueError, match="heuristic"):
        EnvironmentShader(GOLD, env, heuristic="optimal")
    with pytest.raises(ValueError, match="method"):
        EnvironmentShader(GOLD, env, method="quadrature")
    with pytest.raises(ValueError, match="dtype"):
        EnvironmentShader(GOLD, env, dtype=np.int32)
    with pytest.raises(ValueError, match="per-pixel"):
        EnvironmentShader(Lambertian(np.full((8, 8, 3), 0.5)) + GOLD, env)
    with pytest.raises(ValueError, match="compiled"):
        render_sphere(GOLD, env, resolution=8, samples=2, compiled="yes")
    with pytest.raises(ValueError, match="samples"):
        EnvironmentShader(GOLD, env)(np.array([0.0, 0.0, 1.0]), samples=0)


def test_where_the_kernel_does_not_apply_shade_falls_back_to_numpy():
    env = _map()
    textured = Lambertian(np.full((8, 8, 3), 0.5)) + GOLD  # a per-pixel albedo
    sky = [env, DirectionalLight((0, 0, 1), 1.0)]
    for brdf, lights, method in [
        (textured, env, "auto"),
        (GOLD, env, "brdf"),
        (GOLD, [env, env], "mis"),
    ]:
        expected = render_sphere(
            brdf, lights, resolution=8, samples=2, method=method, compiled=False
        )
        image = render_sphere(brdf, lights, resolution=8, samples=2, method=method, compiled=True)
        np.testing.assert_array_equal(image, expected)
    assert compiled_shader(GOLD, sky, method="auto") is not None
    assert compiled_shader(GOLD, [env, SphereLight((0, 0, 3), 0.5, 1.0)], method="auto") is None


@pytest.mark.slow
def test_sums_scaled_lobes_and_delta_lights_equal_numpy_path():
    brdf = Lambertian([0.3, 0.2, 0.1]) + 0.5 * GOLD + 0.3 * RoughConductor(alpha=0.5)
    lights = [
        DirectionalLight((1, 0.3, 0.5), 2.0),
        _map(2, _rotation()),
        PointLight((2, 1, 1), 3.0),
    ]
    g = gbuffer(Sphere(), None, 12)
    expected = shade(g, brdf, lights, samples=8, seed=3, compiled=False)
    image = shade(g, brdf, lights, samples=8, seed=3, compiled="float64")
    np.testing.assert_allclose(image, expected, rtol=1e-11, atol=1e-13)


@pytest.mark.slow
def test_the_default_compiles_even_a_small_render():
    model = RoughConductor(alpha=0.35, material="Cu", masking="smith_separable")
    env = _map()
    g = gbuffer(Sphere(), None, 10)
    assert not kernels_built(model)
    assert pending_kernels(model, [env]) is not None
    image = shade(g, model, env, samples=4, seed=1)  # 300 pixel-samples: compiled all the same
    assert kernels_built(model)
    assert pending_kernels(model, [env]) is None
    np.testing.assert_array_equal(image, shade(g, model, env, samples=4, seed=1, compiled=True))
    numpy_image = shade(g, model, env, samples=4, seed=1, compiled=False)
    assert not np.array_equal(image, numpy_image)  # float32 kernels, not the NumPy path
    scale = np.max(numpy_image)
    assert np.max(np.abs(image - numpy_image)) < 1e-3 * scale


def test_nothing_is_pending_where_the_compiled_path_does_not_apply():
    env = _map()
    assert pending_kernels(GOLD, [DirectionalLight((0, 0, 1), 1.0)]) is None
    assert pending_kernels(GOLD, [env, env]) is None
    assert pending_kernels(GOLD, [env], method="brdf") is None
    assert pending_kernels(Lambertian(0.5), [env]) is None  # exact: no kernels


def test_a_build_records_its_seconds_as_the_next_estimate():
    env = _map()
    seconds = build_kernels(GOLD, [env])  # built by the tests above, or loaded from disk
    assert seconds > 0
    assert build_estimate() == pytest.approx(seconds)
    assert pending_kernels(GOLD, [env]) is None
    assert build_kernels(GOLD, [DirectionalLight((0, 0, 1), 1.0)]) == 0.0
    assert BUILD_SECONDS > 0


def test_a_second_parameter_set_reuses_the_shading_kernels(monkeypatch):
    from brdfkit.compiled import compiled_brdf
    from brdfkit.compiled import kernel as kernel_module

    first = RoughConductor(alpha=0.25, material="Cu", masking="smith_separable")
    second = RoughConductor(alpha=0.6, material="Cu", masking="smith_separable")
    env = _map()
    EnvironmentShader(first, env, dtype=np.float64).build()
    assert kernels_built(second, np.float64)
    monkeypatch.setattr(
        compiled_brdf, "compile_traced", lambda *a, **k: pytest.fail("compiled again")
    )
    monkeypatch.setattr(
        kernel_module, "numba_kernel", lambda *a, **k: pytest.fail("compiled again")
    )
    g = gbuffer(Sphere(), None, 12)
    for model in (second, first):
        expected = shade(g, model, env, samples=8, seed=5, compiled=False)
        image = shade(g, model, env, samples=8, seed=5, compiled="float64")
        np.testing.assert_allclose(image, expected, rtol=1e-11, atol=1e-13)


def test_render_sphere_keeps_the_set_up_of_the_most_recent_inputs(monkeypatch):
    """A second render of the same inputs skips prepare (frames, floor, irradiance) and
    equals an uncached render; other inputs replace the kept work."""
    env, other = _map(), RoughConductor(alpha=0.45, material="Cu", masking="smith_separable")
    calls = []
    prepare = EnvironmentShader.prepare
    monkeypatch.setattr(
        EnvironmentShader,
        "prepare",
        lambda self, *a, **k: calls.append(1) or prepare(self, *a, **k),
    )
    kwargs = {"samples": 8, "compiled": True, "max_evaluations": 2_000}  # several tiles
    first = render_sphere(GOLD, env, 16, seed=3, **kwargs)
    tiles = len(calls)
    assert tiles > 1
    np.testing.assert_array_equal(render_sphere(GOLD, env, 16, seed=3, **kwargs), first)
    again = render_sphere(GOLD, env, 16, seed=4, **kwargs)
    assert len(calls) == tiles  # nothing prepared again
    fresh = shade(gbuffer(Sphere(), None, 16), GOLD, env, seed=4, **kwargs)
    np.testing.assert_array_equal(again, fresh)
    assert len(calls) == 2 * tiles
    calls.clear()
    changed = render_sphere(other, env, 16, seed=4, **kwargs)
    assert len(calls) == tiles and not np.array_equal(changed, again)
    env2 = _map(2)
    expected = shade(gbuffer(Sphere(), None, 16), GOLD, env2, seed=4, **kwargs)
    np.testing.assert_array_equal(render_sphere(GOLD, env2, 16, seed=4, **kwargs), expected)
    numpy_image = render_sphere(GOLD, env, 16, seed=4, **{**kwargs, "compiled": False})
    assert not np.array_equal(numpy_image, again)
    np.testing.assert_array_equal(render_sphere(GOLD, env, 16, seed=4, **kwargs), again)


@pytest.mark.parametrize("count", [1, 255, 1024, 1025, 7300, 9472])
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_task_bounds_split_a_tile_evenly(count, workers):
    """The thread pool's tasks over a tile: contiguous, covering it, at most _CHUNK pixels
    each, a multiple of the workers in number, and equal in size to within a pixel."""
    from brdfkit.render.compiled_shading import _CHUNK, _task_bounds

    bounds = np.array(_task_bounds(count, workers))
    sizes = np.diff(bounds)
    assert bounds[0] == 0 and bounds[-1] == count and np.all(sizes >= 0)
    assert len(sizes) % workers == 0 and sizes.max() <= _CHUNK
    assert sizes.max() - sizes.min() <= 1


def test_scramble_keys_are_the_shared_hash_of_seed_and_slot():
    """sampling.scramble_keys (NumPy) and the tile kernel (numba) hash the same key_hash of a
    pixel's seed at key_slot(stream, i · dim + k): recomputed here slot by slot."""
    seeds = sampling.query_seeds(5, 40)
    for stream, dim in ((0, 3), (1, 2)):
        keys = sampling.scramble_keys(seeds, stream, dim)
        for i in range(2):
            for k in range(dim):
                slot = np.array([sampling.key_slot(stream, i * dim + k)])  # wrapping: no warning
                expected = sampling.key_hash(seeds, slot).astype(np.uint32)
                np.testing.assert_array_equal(keys[:, i, k], expected)


def test_the_command_line_renders_on_the_kernels_as_the_numpy_path(tmp_path):
    from typer.testing import CliRunner

    from brdfkit.cli import app
    from brdfkit.io import read_image, write_image
    from brdfkit.light.spec import parse_light

    light = f"envmap:{tmp_path / 'map.exr'}"
    write_image(tmp_path / "map.exr", _map().image.astype(np.float32))
    out = tmp_path / "gold.exr"
    args = ["render", "-b", GOLD.to_spec(), "-l", light, "-r", "12", "-s", "8", "-o", out]
    result = CliRunner().invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    g = gbuffer(Sphere(), None, 12)
    env = parse_light(light)
    image = read_image(out)
    np.testing.assert_array_equal(image, shade(g, GOLD, env, samples=8).astype(np.float32))
    expected = shade(g, GOLD, env, samples=8, compiled=False)
    scale = np.max(expected)
    assert np.max(np.abs(image - expected)) < 1e-3 * scale
    assert np.median(np.abs(image - expected)[g.mask]) < 1e-5 * scale


def test_the_command_line_says_once_that_it_compiles(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from brdfkit.cli import app
    from brdfkit.render import compiled_shading

    built = []
    monkeypatch.setattr(compiled_shading, "pending_kernels", lambda brdf, lights: brdf)
    monkeypatch.setattr(compiled_shading, "build_estimate", lambda: 7.2)
    monkeypatch.setattr(compiled_shading, "build_kernels", lambda b, l: built.append(b) or 1.0)
    args = ["render", "-b", "ggx(alpha=0.3)", "-l", "directional:0,0,1", "-r", "8", "-s", "1"]
    result = CliRunner().invoke(app, [*args, "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 0, result.output
    assert result.stderr.splitlines() == ["compiling kernels for ggx (once, ~7 s)"]
    assert len(built) == 1


def test_one_tile_kernel_serves_every_model_compiled_to_its_stated_signature():
    """The BRDF's kernels are arguments of the tile kernel (first-class functions): two model
    structures share one compiled tile kernel, whose one specialisation is the signature a
    worker process compiles ahead of the first call."""
    from brdfkit.render._reflection_kernels import tile_kernel, tile_signature

    g = gbuffer(Sphere(), None, 8)
    env = _map()
    correlated = RoughConductor(alpha=0.3, material="Au")  # another structure than GOLD's
    for model in (GOLD, correlated):
        image = shade(g, model, env, samples=4, seed=1)
        expected = shade(g, model, env, samples=4, seed=1, compiled=False)
        assert np.max(np.abs(image - expected)) < 1e-3 * np.max(expected)
    kernel = tile_kernel(np.float32, 3, 3)
    assert [tuple(s) for s in kernel.signatures] == [tile_signature(np.float32, 3, 3)]


def test_a_build_starts_a_worker_only_for_a_tile_kernel_it_lacks(monkeypatch):
    from brdfkit.compiled import worker
    from brdfkit.render import compiled_shading

    started = []
    monkeypatch.setattr(worker, "start", lambda *a, **options: started.append((a, options)))
    built = {(np.float32, 3, 3, False)}
    monkeypatch.setattr(compiled_shading, "tile_kernel_built", lambda *a: a in built)
    env, grey = _map(), EnvironmentMap(np.ones((8, 16, 1)))
    with compiled_shading._tile_worker(GOLD, [env], "auto", np.dtype(np.float32)) as found:
        assert found is None and started == []
    with compiled_shading._tile_worker(GOLD, [grey], "auto", np.dtype(np.float64)):
        pass
    call = ("brdfkit.render._reflection_kernels", "build_tile_kernel", "float64", 3, 1, False)
    assert started == [(call, {"absent": ("scipy",)})]
    assert compiled_shading._tile_worker(Lambertian(0.5), [env], "auto", np.dtype("f4"))


def test_a_new_maps_set_up_runs_on_the_helper_thread_with_the_same_image(monkeypatch):
    """A new map's sampling tables and every tile's set-up after the first are made on the
    helper thread (while the G-buffer is traced and the tile before is shaded), and the image
    equals the one made with all of it on the calling thread, to the bit."""
    import concurrent.futures
    import threading

    from brdfkit.light import environment
    from brdfkit.render import compiled_shading

    pytest.importorskip("numba")
    options = {"resolution": 24, "samples": 4, "seed": 7, "max_evaluations": 2000}
    threads: dict[str, set[threading.Thread]] = {"weights": set(), "prepare": set()}

    def recorded(name, function):
        def call(*args, **kwargs):
            threads[name].add(threading.current_thread())
            return function(*args, **kwargs)

        return call

    monkeypatch.setattr(
        environment, "_sampling_weights", recorded("weights", environment._sampling_weights)
    )
    monkeypatch.setattr(
        EnvironmentShader, "prepare", recorded("prepare", EnvironmentShader.prepare)
    )
    helped = render_sphere(GOLD, _map(seed=21), **options)
    main = threading.current_thread()
    assert threads["weights"] and main not in threads["weights"]
    assert main in threads["prepare"] and len(threads["prepare"]) == 2

    def on_this_thread(function):
        future = concurrent.futures.Future()
        future.set_result(function())
        return future

    monkeypatch.setattr(compiled_shading, "_in_background", on_this_thread)
    threads["prepare"].clear()
    alone = render_sphere(GOLD, _map(seed=21), **options)
    assert threads["prepare"] == {main}
    np.testing.assert_array_equal(helped, alone)
