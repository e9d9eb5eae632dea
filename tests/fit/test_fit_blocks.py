"""The fit's cache-friendly structure gives the same numbers as the plain computation: table
nodes row by row, errors block by block, the lobe Jacobian's skipped channels, the kept lobe values,
and the reflection-only masking term."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.brdf.microfacet import GGX, masking_shadowing
from brdfkit.fit import analytic as fitting
from brdfkit.geometry import half_vector
from brdfkit.measured import MeasuredSamples, TabulatedBRDF
from brdfkit.sampling import hemisphere_pairs

MODEL = "lambertian(rho=[0.3, 0.2, 0.1]) + [0.4, 0.5, 0.6] * ggx(alpha=0.2)"
REFLECTION_MODELS = (
    "ggx(alpha=0.2)",
    "ggx(alpha_u=0.05, alpha_v=0.4, material='Au')",
    "beckmann(alpha=0.3)",
    "cook_torrance(m=0.3, masking='smith_correlated')",
)


def _table(shape: tuple[int, ...], seed: int = 0) -> TabulatedBRDF:
    """A table with random values, some nodes unmeasured (negative) or not finite."""
    rng = np.random.default_rng(seed)
    values = rng.random((*shape, 3))
    values[rng.random(shape) < 0.1] = -1.0
    values[rng.random(shape) < 0.02, 1] = np.nan
    return TabulatedBRDF(values, [1.0, 0.8, 0.6], name="random")


@pytest.mark.parametrize("shape", [(9, 10, 20), (5, 6, 7, 8)])
def test_table_nodes_row_by_row_equal_all_at_once(shape):
    table = _table(shape)
    wi, wo = (w.reshape(-1, 3) for w in table.node_directions())
    values = table.scaled_values().reshape(-1, 3)
    valid = MeasuredSamples(wi, wo, values).valid
    assert 0 < valid.sum() < valid.size
    data = fitting.fit_data(table)
    assert data.name == "random"
    np.testing.assert_array_equal(data.wi, wi[valid])
    np.testing.assert_array_equal(data.wo, wo[valid])
    np.testing.assert_array_equal(data.values, values[valid])


@pytest.mark.parametrize("block", [64, 1000, 8192])
def test_errors_block_by_block_equal_the_formulas_on_all_samples(monkeypatch, block):
    wi, wo = hemisphere_pairs(2500, 1)
    truth = parse(MODEL)
    data = MeasuredSamples(wi, wo, truth.eval(wi, wo) * np.array([1.1, 0.9, 1.3]))
    model = parse("lambertian(rho=[0.25, 0.2, 0.15]) + [0.3, 0.5, 0.7] * ggx(alpha=0.25)")
    f, v, c = model.eval(wi, wo), data.values, wi[:, 2:3]
    s = np.median((v * c).mean(axis=1))  # the log objective's level: the data's typical f cos
    expected = {
        "rmse": np.sqrt(np.mean((f - v) ** 2)),
        "cosine_rmse": np.sqrt(np.mean(((f - v) * c) ** 2)),
        "relative_l2": np.linalg.norm(f - v) / np.linalg.norm(v),
        "log_rmse": np.sqrt(
            np.mean((np.log1p(np.maximum(f, 0) * c / s) - np.log1p(v * c / s)) ** 2)
        ),
        "cube_root_rmse": np.sqrt(np.mean((np.cbrt(f * c) - np.cbrt(v * c)) ** 2)),
    }
    monkeypatch.setattr(fitting, "_BLOCK", block)
    errors = fitting.fit_errors(model, data)
    assert errors.keys() == expected.keys()
    for name, value in expected.items():
        assert errors[name] == pytest.approx(value, rel=1e-12, abs=0), name


def _problem(objective: str = "cube_root"):
    wi, wo = hemisphere_pairs(300, 2)
    data = MeasuredSamples(wi, wo, parse(MODEL).eval(wi, wo))
    lobes = fitting._lobes(parse("lambertian + 0.5 * ggx(alpha=0.15)"))
    free = fitting._free_parameters(lobes, [set(), set()], (), 3)
    x = np.concatenate([p.initial for p in free])
    lower = np.concatenate([np.full(p.size, p.lower) for p in free])
    upper = np.concatenate([np.full(p.size, p.upper) for p in free])
    return (
        lobes,
        free,
        data,
        x,
        lower,
        upper,
        fitting._Robust(objective, "linear", 1.0, fitting.log_scale(data)),
    )


@pytest.mark.parametrize("objective", ["cosine", "log", "cube_root"])
@pytest.mark.parametrize("channels", [slice(None), slice(1, 2)])
def test_lobe_jacobian_columns_are_the_whole_models_differences(objective, channels):
    """Each column is (r(x + h e) - r(x)) / h of the whole model's residuals in ``channels``
    (to the rounding of the differences); a factor's column is exactly 0 in the channels its
    step does not move, which are not recomputed."""
    lobes, free, data, x, lower, upper, robust = _problem(objective)
    model = fitting._LobeValues(lobes, free, data)
    ours = model.jacobian(x, np.arange(x.size), lower, upper, robust, channels)
    r0 = fitting.residuals(fitting._assemble(lobes, free, x, relax=True), data, objective)
    assert ours.shape == (r0[:, channels].size, x.size)
    for i, (p, j) in enumerate(model.owner):
        h = np.sqrt(np.finfo(float).eps) * max(1.0, abs(x[i]))
        h = (x[i] + h) - x[i]  # the step at x is inside the bounds here
        x_step = x.copy()
        x_step[i] += h
        stepped = fitting._assemble(lobes, free, x_step, relax=True)
        r = fitting.residuals(stepped, data, objective)
        column = ((r - r0)[:, channels] / h).reshape(-1)
        np.testing.assert_allclose(ours[:, i], column, rtol=1e-6, atol=1e-6)
        assert np.any(column != 0) or (channels == slice(1, 2) and p.size == 3 and j != 1)
        if p.name == "scale" and channels == slice(None):
            others = ours[:, i].reshape(-1, 3)[:, [k for k in range(3) if k != j]]
            assert np.all(others == 0)


def test_a_lobe_keeps_its_values_while_only_its_factor_changes():
    lobes, free, data, x, *_ = _problem()
    model = fitting._LobeValues(lobes, free, data)
    before = model.values(x)
    factor = next(i for i, (p, _) in enumerate(model.owner) if p.name == "scale")
    colour = next(i for i, (p, _) in enumerate(model.owner) if p.name == "rho")
    moved = x.copy()
    moved[[factor, colour]] += [0.25, 0.1]
    after = model.values(moved)
    assert after[1][0] is before[1][0]  # the GGX lobe: not evaluated again
    assert after[0][0] is not before[0][0]  # the Lambertian: its colour moved
    fresh = fitting._LobeValues(lobes, free, data).values(moved)
    for (g, k), (g_fresh, k_fresh) in zip(after, fresh, strict=True):
        np.testing.assert_array_equal(g, g_fresh)
        np.testing.assert_array_equal(k, k_fresh)


def test_reflection_only_masking_leaves_the_reflection_models_unchanged(monkeypatch):
    """The microfacet reflection models use the reflection form of the height-correlated term
    for every pair; on pairs on one side it is the general term, and the others' value is 0:
    their values equal those with the general term, bit for bit, above and below."""
    from brdfkit.brdf import microfacet_reflection

    rng = np.random.default_rng(5)
    wi, wo = (v / np.linalg.norm(v, axis=1, keepdims=True) for v in rng.normal(size=(2, 4000, 3)))
    h = half_vector(wi, wo)
    same_side = wi[:, 2] * wo[:, 2] > 0
    assert 0 < same_side.sum() < same_side.size
    for distribution in (GGX(0.3, 0.3), GGX(0.05, 0.4)):
        general = masking_shadowing(distribution, wi, wo, h, "smith_correlated")
        reflection = masking_shadowing(
            distribution, wi, wo, h, "smith_correlated", transmission=False
        )
        np.testing.assert_array_equal(reflection[same_side], general[same_side])
    models = [parse(spec) for spec in REFLECTION_MODELS]
    values = [m.eval(wi, wo) for m in models]
    general_term = microfacet_reflection.masking_shadowing

    def always_general(*args, transmission=True):
        return general_term(*args)

    monkeypatch.setattr(microfacet_reflection, "masking_shadowing", always_general)
    for model, value in zip(models, values, strict=True):
        assert np.any(value[same_side] > 0)
        np.testing.assert_array_equal(model.eval(wi, wo), value)


@pytest.mark.parametrize("spec", [MODEL, "cook_torrance(m=0.3, diffuse=0)"])
def test_the_fit_evaluates_compiled_where_one_kernel_serves_every_parameter_set(spec):
    """Once :func:`~brdfkit.fit.analytic.build_kernels` has run, Lambertian + GGX by its compiled
    kernel (the same values to rounding); Cook–Torrance, whose constructor reads ``diffuse``'s value
    (a kernel per parameter set), by NumPy."""
    from brdfkit import compiled

    wi, wo = hemisphere_pairs(3000, 3)
    model = parse(spec)
    fitting.build_kernels(model)
    ours, theirs = fitting._evaluated(model, wi, wo), np.asarray(model.eval(wi, wo))
    if compiled.compile(model, np.float64).shares("eval"):
        assert spec == MODEL
        np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=0)
    else:
        np.testing.assert_array_equal(ours, theirs)
