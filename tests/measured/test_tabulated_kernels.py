"""Tabulated BRDFs on the compiled shading path equal the NumPy path, and sample unbiasedly."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("numba")

from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.brdf.base import Scaled
from brdfkit.light import EnvironmentMap
from brdfkit.measured import TabulatedBRDF, table_kernels
from brdfkit.render import Sphere, gbuffer, shade
from brdfkit.render.compiled_shading import compiled_shader, kernels_built
from brdfkit.sampling import square_to_uniform_sphere

COPPER = RoughConductor(alpha=0.3, material="Cu", masking="smith_separable")


@pytest.fixture(scope="module")
def table() -> TabulatedBRDF:
    return TabulatedBRDF.from_brdf(COPPER, (16, 16, 32), channels=3)


@pytest.fixture(scope="module")
def anisotropic() -> TabulatedBRDF:
    return TabulatedBRDF.from_brdf(COPPER, (8, 6, 8, 12), channels=3)


def _pairs(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Random pairs, a quarter of them with a direction below the surface."""
    rng = np.random.default_rng(seed)
    wi = square_to_uniform_sphere(rng.random((n, 2)))
    wo = square_to_uniform_sphere(rng.random((n, 2)))
    wi[: n // 2, 2] = np.abs(wi[: n // 2, 2])
    wo[n // 4 :, 2] = np.abs(wo[n // 4 :, 2])
    return wi, wo


def _kernel_calls(model, dtype, wi, wo, u):
    """The compiled eval, pdf and sample (wi, weight, pdf) on flat buffers."""
    kernels = table_kernels(model, dtype)
    sample_fn, eval_fn, pdf_fn = kernels.functions
    n, c = wi.shape[0], model.channels
    flat = [np.ascontiguousarray(v, dtype).ravel() for v in (wi, wo, u)]
    f, p = np.empty(n * c, dtype), np.empty(n, dtype)
    eval_fn(kernels.parameters, flat[0], flat[1], f, n, *kernels.data)
    pdf_fn(kernels.parameters, flat[0], flat[1], p, n, *kernels.data)
    s_wi, s_w = np.empty(3 * n, dtype), np.empty(n * c, dtype)
    s_p, delta = np.empty(n, dtype), np.empty(n, bool)
    sample_fn(kernels.parameters, flat[1], flat[2], s_wi, s_w, s_p, delta, n, *kernels.data)
    assert not delta.any()
    return f.reshape(n, c), p, s_wi.reshape(n, 3), s_w.reshape(n, c), s_p


@pytest.mark.parametrize(
    ("interpolation", "rank"),
    [
        pytest.param(i, r, marks=pytest.mark.slow)  # numba compilations (~10 s each)
        for i, r in [
            ("linear", 3),
            ("bin", 3),
            ("nearest", 3),
            ("linear", 4),
            ("bin", 4),
            ("nearest", 4),
        ]
    ],
)
def test_kernels_equal_numpy_eval_pdf_sample(table, anisotropic, interpolation, rank):
    base = table if rank == 3 else anisotropic
    model = TabulatedBRDF(base.values, interpolation=interpolation)
    wi, wo = _pairs(4000)
    u = np.random.default_rng(2).random((4000, 3))
    for dtype, rtol in ((np.float64, 1e-11), (np.float32, 2e-4)):
        a, b, u_t = wi.astype(dtype), wo.astype(dtype), u.astype(dtype)
        f, p, s_wi, s_w, s_p = _kernel_calls(model, dtype, a, b, u_t)
        scale = np.max(model.eval(a, b))
        np.testing.assert_allclose(f, model.eval(a, b), rtol=rtol, atol=rtol * scale)
        np.testing.assert_allclose(p, model.pdf(a, b), rtol=rtol, atol=rtol)
        s = model.sample(b, u_t)
        np.testing.assert_allclose(s_wi, s.wi, rtol=rtol, atol=rtol)
        close = np.isclose(s_w, s.weight, rtol=10 * rtol, atol=10 * rtol * scale)
        # float32: a direction on a cell boundary may land in the neighbour cell
        assert np.mean(close) > (1 - 1e-11 if dtype == np.float64 else 0.998)
        np.testing.assert_allclose(s_p, s.pdf, rtol=10 * rtol, atol=rtol)


@pytest.mark.slow  # a numba compilation (~10 s)
def test_sample_rows_with_empty_theta_h_cells(table):
    """The guide-table search of the θh marginal finds bisection's rows where the CDF has
    flat runs (cells without energy), including a first and a last empty cell."""
    values = np.array(table.values)
    values[[0, 3, 4, 5, 9, -1]] = 0.0
    model = TabulatedBRDF(values, interpolation="bin")
    assert np.any(np.diff(model.half_vector_sampling._distribution._marginal) == 0)
    _, wo = _pairs(4000, seed=4)
    u = np.random.default_rng(5).random((4000, 3))
    u[:8, 1] = model.half_vector_sampling._distribution._marginal[:8]  # on CDF nodes
    _, _, s_wi, _, s_p = _kernel_calls(model, np.float64, wo, wo, u)
    s = model.sample(wo, u)
    np.testing.assert_allclose(s_wi, s.wi, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(s_p, s.pdf, rtol=1e-10, atol=1e-11)


def test_scaled_table_scales_values_and_weights(table):
    k = np.array([0.5, 1.0, 2.0])
    wi, wo = _pairs(500)
    u = np.random.default_rng(3).random((500, 3))
    f, p, _, s_w, _ = _kernel_calls(Scaled(k, table), np.float64, wi, wo, u)
    f0, p0, _, w0, _ = _kernel_calls(table, np.float64, wi, wo, u)
    np.testing.assert_allclose(f, k * f0, rtol=1e-14)
    np.testing.assert_allclose(s_w, k * w0, rtol=1e-14)
    np.testing.assert_array_equal(p, p0)
    assert table_kernels(COPPER, np.float64) is None


def test_sampler_is_unbiased(table):
    """E[weight] = ∫ f cos θi dω (the directional albedo), by quadrature of the NumPy eval."""
    wo = np.array([math.sin(0.9), 0.0, math.cos(0.9)])
    n = 400_000
    u = np.random.default_rng(5).random((n, 3))
    _, _, _, weight, pdf = _kernel_calls(table, np.float64, np.tile(wo, (n, 1)),
                                         np.tile(wo, (n, 1)), u)  # fmt: skip
    assert np.mean(pdf > 0) > 0.8  # the rest: reflected below the surface, weight 0
    # midpoint quadrature in (cos θ, φ): dω = d(cos θ) dφ
    m = 400
    mu = (np.arange(m) + 0.5) / m
    phi = (np.arange(2 * m) + 0.5) / (2 * m) * 2 * math.pi
    c, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - c * c)
    wi = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1).reshape(-1, 3)
    albedo = np.sum(table.eval(wi, wo) * wi[:, 2:], axis=0) * (1 / m) * (math.pi / m)
    mean, stderr = weight.mean(axis=0), weight.std(axis=0) / math.sqrt(n)
    assert np.all(np.abs(mean - albedo) < 4 * stderr + 2e-3 * albedo)


def _map() -> EnvironmentMap:
    image = np.random.default_rng(1).random((16, 32, 3)) ** 4 * 5
    return EnvironmentMap(image, scale=1.5)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["table", "lambertian+table", "scaled"])
def test_render_compiled_equals_numpy_path(table, kind):
    brdf = {
        "table": table,
        "lambertian+table": Lambertian([0.2, 0.1, 0.05]) + table,
        "scaled": 0.5 * table,
    }[kind]
    g = gbuffer(Sphere(), None, 12)
    env = _map()
    assert compiled_shader(brdf, [env], method="auto") is not None
    expected = shade(g, brdf, env, samples=8, seed=5, max_evaluations=1_500, compiled=False)
    image = shade(g, brdf, env, samples=8, seed=5, max_evaluations=1_500, compiled="float64")
    np.testing.assert_allclose(image, expected, rtol=1e-9, atol=1e-12)
    image32 = shade(g, brdf, env, samples=8, seed=5, max_evaluations=1_500, compiled=True)
    scale = np.max(expected)
    assert np.median(np.abs(image32 - expected)[g.mask]) < 1e-5 * scale
    assert np.mean(np.abs(image32 - expected)[g.mask]) < 1e-4 * scale
    assert kernels_built(table, np.float32)


@pytest.mark.slow
def test_render_converges_to_the_numpy_reference(table):
    """Different seeds, many samples: the compiled estimate is the NumPy one's expectation."""
    g = gbuffer(Sphere(), None, 8)
    env = _map()
    reference = shade(g, table, env, samples=512, seed=1, compiled=False)
    image = shade(g, table, env, samples=512, seed=77, compiled=True)
    m = g.mask
    error = np.sqrt(np.mean((image - reference)[m] ** 2)) / np.sqrt(np.mean(reference[m] ** 2))
    assert error < 0.03


def test_broadcast_eval_in_chunks_equals_one_kernel_call(table):
    """``TableKernels.eval`` (the control variate's floor) runs in chunks of EVAL_CHUNK pairs
    on the kernels' threads: over several chunks and a partial one, bit-identical to one call
    over all pairs."""
    from brdfkit.measured._tabulated_kernels import EVAL_CHUNK

    kernels = table_kernels(table, np.float64)
    wi, wo = _pairs(EVAL_CHUNK // 8 + 37)
    directions = wi[:16]  # (16, 3) against every wo: broadcast as in the floor
    f = kernels.eval(directions, wo[:, None, :])
    assert f.shape == (wo.shape[0], 16, 3) and wo.shape[0] * 16 > 2 * EVAL_CHUNK
    a, b = np.broadcast_arrays(directions, wo[:, None, :])
    n = a.shape[0] * a.shape[1]
    expected = np.empty(n * 3)
    kernels.functions[1](
        kernels.parameters, a.reshape(-1).copy(), b.reshape(-1).copy(), expected, n,
        *kernels.data,
    )  # fmt: skip
    assert np.array_equal(f.reshape(-1), expected)


def test_a_render_without_tables_does_not_import_the_measured_package():
    """The shading kernels ask whether a model is tabulated; where no table's class was ever
    imported none can be, and the answer costs no import of :mod:`brdfkit.measured`."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np\n"
        "from brdfkit.brdf import parse\n"
        "from brdfkit.render.compiled_shading import _table_kernels\n"
        "print(_table_kernels(parse('ggx(alpha=0.3)'), np.float32),"
        " 'brdfkit.measured' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["None", "False"]


def test_a_tabulated_model_is_still_found_by_the_shading_kernels(table):
    from brdfkit.render.compiled_shading import _table_kernels

    assert _table_kernels(table, np.float64) is table_kernels(table, np.float64)
    assert _table_kernels(COPPER, np.float64) is None
