"""The compiled kernels of :mod:`brdfkit.vision.bivariate_stereo` against their readable NumPy
versions in :mod:`brdfkit.vision.bivariate_reference`: the shared table's least-squares system,
the trims from one sort, the warm-started non-negative fits and the per-pixel stopping of the
normal search."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import (
    _bivariate_stereo_kernels,
    bivariate_reference,
    bivariate_stereo,
    datasets,
    photometric_stereo,
)
from brdfkit.vision.bivariate_stereo import _half_vectors
from brdfkit.vision.photometric_stereo import _trim_weights


@pytest.fixture(scope="module")
def glossy():
    """A 24-pixel glossy sphere under 96 DiLiGenT-like lights: gray ``(N, P)``, lights, shadow
    weights ``(P, N)``, start normals ``(S, P, 3)``, true normals ``(P, 3)``."""
    normals, mask = photometric_stereo.sphere_normals((24, 24), (11.5, 11.5), 11.0)
    lights = datasets.diligent_like_lights()
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=[0.6, 0.4, 0.3], specular=1.0, shininess=30.0,
        noise=0.002, rng=np.random.default_rng(1),
    )  # fmt: skip
    gray = data.images.mean(axis=3)[:, mask]
    lit, starts = bivariate_stereo._start(gray, data.light_directions, 0.05)
    return gray, data.light_directions, lit, starts, normals[mask]


def _table(n_h=12, n_d=4):
    table = bivariate_stereo._Table(n_h, n_d)
    theta_h = (np.linspace(0.0, 1.0, n_h) ** 2) * (np.pi / 2)
    table.values = np.repeat(np.exp(-((theta_h / np.radians(10.0)) ** 2)), n_d)
    return table


@pytest.mark.parametrize("bins", [(12, 4), (24, 6), (5, 2)])
def test_table_fit_matches_numpy(glossy, bins):
    gray, lights, lit, _, truth = glossy
    table = _table(*bins)
    rng = np.random.default_rng(3)
    normals = truth + 0.05 * rng.standard_normal(truth.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    _, coefficients = bivariate_stereo._residuals(
        normals, gray.T, lit, lights, bivariate_stereo._shared_basis(table), True
    )
    assert (coefficients[:, 1] > 0).mean() > 0.5  # a specular weight on most pixels
    reference = bivariate_reference.table_fit(
        table, normals, gray.T, lit, lights, coefficients, 1e-2
    )
    bivariate_stereo._fit_table(table, normals, gray.T, lit, lights, coefficients, 1e-2)
    assert table.values.max() == 1.0 and np.ptp(table.values) > 0.5
    np.testing.assert_allclose(table.values, reference, rtol=1e-8, atol=1e-10)


def test_trims_from_one_sort_equal_the_trimmed_weights(glossy):
    gray = glossy[0]
    ranks = bivariate_stereo._ranks(gray)
    for dark, bright in ((0.25, 0.1), (0.25, 0.4), (0.1, 0.6), (0.0, 0.3), (0.25, 0.25)):
        np.testing.assert_array_equal(
            bivariate_stereo._trimmed(ranks, dark, bright), _trim_weights(gray, dark, bright)
        )


def test_start_kernel_equals_weighted_least_squares(glossy):
    # the compiled trimmed starts against photometric_stereo._weighted_least_squares on the
    # trimmed weights (normalised; the view where b = 0, here the all-dark pixel added)
    gray, lights = glossy[0], glossy[1]
    gray = np.concatenate([gray, np.zeros((len(gray), 1))], axis=1)
    ranks = bivariate_stereo._ranks(gray)
    _, starts = bivariate_stereo._start(gray, lights, 0.05, ranks)
    assert starts.shape == (3, gray.shape[1], 3)
    for start, (dark, bright) in zip(starts, ((0.25, 0.1), (0.25, 0.4), (0.1, 0.6)), strict=True):
        b = photometric_stereo._weighted_least_squares(
            gray, lights, bivariate_stereo._trimmed(ranks, dark, bright)
        ).T
        length = np.linalg.norm(b, axis=1, keepdims=True)
        reference = np.where(length > 0, b / np.where(length > 0, length, 1.0), [0.0, 0.0, 1.0])
        np.testing.assert_allclose(start, reference, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(starts[:, -1], [[0.0, 0.0, 1.0]] * 3)
    assert (np.abs(starts[0] - starts[2]).max(axis=1) > 1e-3).any()  # the windows differ


def test_warm_started_nonnegative_fit_equals_a_cold_one(glossy):
    gray, lights, lit, starts, _ = glossy
    knots = np.linspace(0.0, 1.0, 8), np.cos(np.linspace(np.pi / 2, 0.0, 8))
    basis = bivariate_stereo._sum_of_lobes_basis(*knots)
    assert bivariate_stereo._kernel_inputs(lights, basis)[-1]  # the ramps start warm
    normals = starts[0]
    cold_residual, cold, _ = bivariate_stereo._fit(normals, gray.T, lit, lights, basis, True)
    # Start every pixel from an arbitrary active set, then from the previous fit's.
    free = np.random.default_rng(4).random((len(normals), basis.size)) < 0.5
    for _ in range(2):
        residual, warm, _ = bivariate_stereo._fit(normals, gray.T, lit, lights, basis, True, free)
        np.testing.assert_allclose(warm, cold, atol=1e-9 * np.abs(cold).max())
        np.testing.assert_allclose(residual, cold_residual, atol=1e-12 * np.abs(gray).max())
    assert (cold == 0).any() and not free.all()  # the constraint is active somewhere


@pytest.mark.parametrize("name", ["bipolynomial", "ramps"])
def test_normal_search_stops_where_its_steps_vanish(glossy, name):
    gray, lights, lit, starts, _ = glossy
    if name == "bipolynomial":
        basis, nonnegative = bivariate_stereo._bipolynomial_basis(3, 1), False
    else:
        knots = np.linspace(0.0, 1.0, 8), np.cos(np.linspace(np.pi / 2, 0.0, 8))
        basis, nonnegative = bivariate_stereo._sum_of_lobes_basis(*knots), True
    g, w = np.ascontiguousarray(gray.T), np.ascontiguousarray(lit)
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    runs = {}
    for tolerance in (0.0, bivariate_stereo.STEP_TOLERANCE):
        normals = np.array(starts[0], order="C")
        free = np.ones((len(normals), basis.size), dtype=bool)
        residual, _, cost = bivariate_stereo._fit(normals, g, w, lights, basis, nonnegative, free)
        damping, active = np.full(len(normals), 1e-3), np.ones(len(normals), dtype=bool)
        for _ in range(20):
            _bivariate_stereo_kernels.lm_step(
                normals, damping, residual, cost, active, free, g, w, *inputs, nonnegative,
                tolerance,
            )  # fmt: skip
        runs[tolerance] = normals, active
    (full, never), (stopped, active) = runs[0.0], runs[bivariate_stereo.STEP_TOLERANCE]
    assert never.all() and (~active).mean() > 0.5  # most pixels stopped within 20 iterations
    angle = np.degrees(np.arccos(np.clip(np.sum(full * stopped, axis=1), -1.0, 1.0)))
    assert np.median(angle) < 1e-4 and angle.max() < 0.01, (np.median(angle), angle.max())


def _ramps_knots(n=8):
    return np.linspace(0.0, 1.0, n), np.cos(np.linspace(np.pi / 2, 0.0, n))


def test_ramps_system_equals_the_dense_gram(glossy):
    """The ramps' Gram and right-hand side from sums by ramp index equal ``D^T W D`` and
    ``D^T W I`` of the dense design (:func:`bivariate_reference.design` of IA14's
    ``g(n·l) + s(n·h)``), also for normals far off."""
    gray, lights, lit, starts, _ = glossy
    knots_i, knots_h = _ramps_knots()
    half, _ = _half_vectors(lights)
    rng = np.random.default_rng(5)
    normals = starts[0] + 0.5 * rng.standard_normal(starts[0].shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    steps = len(knots_i) - 1
    scratch = [np.empty((len(lights), 2), np.int64), np.empty((len(lights), 2))]
    scratch += [np.empty((4, steps + 1, steps + 1)), np.empty((6, steps + 1))]
    basis = bivariate_stereo._sum_of_lobes_basis(knots_i, knots_h)
    for p, n in enumerate(normals):
        kept = np.flatnonzero(lit[p])
        cos_i, cos_h = lights[kept] @ n, half[kept] @ n
        unused_cos_d = np.zeros((1, len(kept)))  # the ramps see cos θ_i and cos θ_h only
        design = bivariate_reference.design(basis, cos_i[None], cos_h[None], unused_cos_d)[0]
        w, g = lit[p, kept], gray[kept, p]
        gram, rhs = np.full((2 * steps, 2 * steps), np.nan), np.empty(2 * steps)
        _bivariate_stereo_kernels._ramps_system(
            *n, kept, g, w, len(kept), lights, half, knots_i, knots_h, gram, rhs, *scratch
        )
        upper = np.triu_indices(2 * steps)
        reference = (design.T * w) @ design
        np.testing.assert_allclose(gram[upper], reference[upper], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(rhs, (design.T * w) @ g, rtol=1e-12, atol=1e-12)


def _basis(name: str) -> tuple[bivariate_stereo.Basis, bool]:
    """The basis of each of the three methods, and whether its weights are non-negative."""
    if name == "bipolynomial":
        return bivariate_stereo._bipolynomial_basis(3, 1), False
    if name == "ramps":
        return bivariate_stereo._sum_of_lobes_basis(*_ramps_knots()), True
    return bivariate_stereo._shared_basis(_table()), True


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_best_start_kernel_equals_numpy(glossy, name):
    gray, lights, lit, starts, _ = glossy
    basis, nonnegative = _basis(name)
    g, w = np.ascontiguousarray(gray.T), np.ascontiguousarray(lit)
    reference = bivariate_reference.best_start(starts, g, w, lights, basis, nonnegative)
    normals, residual, cost = np.empty((len(g), 3)), np.empty(g.shape), np.empty(len(g))
    free = np.ones((len(g), basis.size), dtype=bool)
    coefficients = np.empty((len(g), basis.size))
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    _bivariate_stereo_kernels.best_start(
        starts, bivariate_stereo.BEST_START_RING, g, w, *inputs, nonnegative, normals, residual,
        cost, free, coefficients,
    )  # fmt: skip
    assert (np.abs(reference - starts[0]).max(axis=1) > 0).any()  # another candidate won
    np.testing.assert_allclose(normals, reference, atol=1e-12)
    ref_residual, ref_weights, ref_cost = bivariate_stereo._fit(
        reference, g, w, lights, basis, nonnegative
    )
    np.testing.assert_allclose(residual, ref_residual, atol=1e-9 * np.abs(gray).max())
    np.testing.assert_allclose(cost, ref_cost, rtol=1e-9)
    if not inputs[-1]:  # cold-started fits: the weights a refit gives (warm-started ramps may
        # settle on other weights of the same residual where two ramps see the same observations)
        np.testing.assert_allclose(coefficients, ref_weights, atol=1e-9 * np.abs(ref_weights).max())


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_screened_start_selection_equals_the_full_one(glossy, name):
    # the ring's normals fitted only where their lower bound is below the best cost: the same
    # winners and costs as fitting all of them (the ramps' weights may differ where their
    # warm-started active sets do, for the same residual)
    gray, lights, lit, starts, _ = glossy
    basis, nonnegative = _basis(name)
    g, w = np.ascontiguousarray(gray.T), np.ascontiguousarray(lit)
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    out = {}
    for screen in (False, True):
        normals, residual, cost = np.empty((len(g), 3)), np.empty(g.shape), np.empty(len(g))
        free = np.ones((len(g), basis.size), dtype=bool)
        _bivariate_stereo_kernels.best_start(
            starts, bivariate_stereo.BEST_START_RING, g, w, *inputs, nonnegative, normals, residual,
            cost, free, np.empty((len(g), basis.size)), screen,
        )  # fmt: skip
        out[screen] = normals, residual, cost
    np.testing.assert_array_equal(out[True][0], out[False][0])
    np.testing.assert_allclose(out[True][2], out[False][2], rtol=1e-12)
    np.testing.assert_allclose(out[True][1], out[False][1], atol=1e-9 * np.abs(gray).max())


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_screening_bound_is_below_the_fit(glossy, name):
    # _lower_bound <= _fit's cost (within the margin) at normals up to ~20° off the truth
    gray, lights, lit, _, truth = glossy
    basis, nonnegative = _basis(name)
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    rng = np.random.default_rng(3)
    normals = truth + rng.normal(scale=0.2, size=truth.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    n_lights, k = len(lights), basis.size
    kept, sub_kept = np.empty(n_lights, np.int64), np.empty(n_lights, np.int64)
    g_kept, w_kept, sub_g, sub_w = (np.empty(n_lights) for _ in range(4))
    scratch = _bivariate_stereo_kernels._scratch(n_lights, k)
    below = 0
    for p, (n, g, w) in enumerate(zip(normals, gray.T, lit, strict=True)):
        m = _bivariate_stereo_kernels._kept(w, g, kept, g_kept, w_kept)
        sub = np.arange(0, m, _bivariate_stereo_kernels.SCREEN_STRIDE)
        sub_kept[: len(sub)], sub_g[: len(sub)], sub_w[: len(sub)] = (
            kept[sub],
            g_kept[sub],
            w_kept[sub],
        )
        bound = _bivariate_stereo_kernels._lower_bound(
            *n, kept, g_kept, w_kept, m, sub_kept, sub_g, sub_w, len(sub), *inputs[:-1],
            nonnegative, np.empty(n_lights), np.empty(k), np.ones(k, dtype=bool), scratch,
        )  # fmt: skip
        cost = _bivariate_stereo_kernels._fit(
            *n, kept, g_kept, w_kept, m, *inputs, nonnegative, np.empty(n_lights), np.empty(k),
            np.ones(k, dtype=bool), scratch,
        )  # fmt: skip
        signal = np.sum(w_kept[:m] * g_kept[:m] ** 2)
        assert bound <= cost + _bivariate_stereo_kernels.SCREEN_MARGIN * signal, p
        below += bound < 0.5 * cost
    assert below > 0  # a bound, not the cost


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_kept_products_through_rejected_steps_change_nothing(glossy, name):
    """The normal search that reuses ``J^T J`` and ``J^T r`` after a rejected step follows the
    one that refits the shifted normals (same normals, damping and stopping)."""
    gray, lights, lit, starts, _ = glossy
    basis, nonnegative = _basis(name)
    g, w = np.ascontiguousarray(gray.T), np.ascontiguousarray(lit)
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    runs = []
    for keep in (False, True):
        normals = np.array(starts[0], order="C")
        free = np.ones((len(normals), basis.size), dtype=bool)
        residual, _, cost = bivariate_stereo._fit(normals, g, w, lights, basis, nonnegative, free)
        damping, active = np.full(len(normals), 1e-3), np.ones(len(normals), dtype=bool)
        products = np.zeros((len(normals), 6)) if keep else None
        rejected = 0
        for _ in range(12):
            before = damping.copy()
            args = (normals, damping, residual, cost, active, free, g, w, *inputs, nonnegative)
            if keep:
                _bivariate_stereo_kernels.lm_step(*args, bivariate_stereo.STEP_TOLERANCE, products)
            else:
                _bivariate_stereo_kernels.lm_step(*args, bivariate_stereo.STEP_TOLERANCE)
            rejected += int((damping > before).sum())
        runs.append((normals, damping, active, rejected))
    (n_0, d_0, a_0, rejected), (n_1, d_1, a_1, _) = runs
    assert rejected > 0  # steps were rejected, so the kept products were used
    np.testing.assert_allclose(n_1, n_0, atol=1e-12)
    np.testing.assert_array_equal(d_1, d_0)
    np.testing.assert_array_equal(a_1, a_0)


def test_diffuse_albedo_kernel_equals_numpy(glossy):
    """The albedo pass of ``_finish`` against :func:`bivariate_reference.diffuse_albedo`, with
    pixels whose trimmed set is empty (all their lit observations then)."""
    gray, lights, lit, starts, _ = glossy
    normals = starts[0]
    weights = lit.copy()
    weights[:3, :60] = 0.0  # few lit observations left: none of middle rank on these pixels
    ranks = bivariate_stereo._ranks(gray)
    rho_ref, use_ref = bivariate_reference.diffuse_albedo(normals, gray, weights, lights, ranks)
    cos_theta_i = np.clip(normals @ lights.T, 0.0, None)
    trim = bivariate_stereo._trimmed(ranks, 0.25, 0.25).T * weights * (cos_theta_i > 0.1)
    use = np.empty(ranks.shape)
    n_trim = int(np.floor(0.25 * len(lights)))
    rho = _bivariate_stereo_kernels.diffuse_albedo(
        normals, gray, np.ascontiguousarray(weights), lights, ranks, n_trim, n_trim, use
    )
    assert (trim.sum(axis=1) == 0).any()  # the fallback to all lit observations was taken
    np.testing.assert_array_equal(use, use_ref)
    np.testing.assert_allclose(rho, rho_ref, rtol=1e-12)


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_analytic_jacobian_equals_central_differences(glossy, name):
    """The search's ``J^T J`` and ``J^T r`` (the exact variable-projection Jacobian) equal those
    of central differences of the refitted residual in the tangent coordinates, on normals near
    and far from the truth (the designs are piecewise smooth: a few pixels may sit on a kink or
    change active set within the difference step). The bi-polynomial's ill-conditioned fit
    rounds its residual at ~1e-11 relative: a wider step, whose error is then O(step^2)."""
    gray, lights, lit, _, truth = glossy
    basis, nonnegative = _basis(name)
    g, w = np.ascontiguousarray(gray.T), np.ascontiguousarray(lit)
    rng = np.random.default_rng(6)
    normals = truth + 0.1 * rng.standard_normal(truth.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    residual, _, cost = bivariate_stereo._fit(normals, g, w, lights, basis, nonnegative)
    products = np.zeros((len(normals), 6))
    free = np.ones((len(normals), basis.size), dtype=bool)
    active = np.ones(len(normals), dtype=bool)
    _bivariate_stereo_kernels.lm_step(
        np.array(normals), np.full(len(normals), 1e-3), residual.copy(), cost, active, free, g,
        w, *bivariate_stereo._kernel_inputs(lights, basis), nonnegative, np.inf, products,
    )  # fmt: skip
    assert not active.any() and (products[:, 5] == 1).all()  # each pixel's products, no step
    t_1, t_2 = bivariate_stereo._tangent_frame(normals)
    step = 1e-4 if name == "bipolynomial" else 1e-6
    columns = []
    for t in (t_1, t_2):
        shifted = []
        for sign in (1, -1):
            moved = normals + sign * step * t
            moved /= np.linalg.norm(moved, axis=1, keepdims=True)
            shifted.append(bivariate_stereo._fit(moved, g, w, lights, basis, nonnegative)[0])
        columns.append((shifted[0] - shifted[1]) / (2 * step))
    j_0, j_1 = columns
    reference = np.stack(
        [
            np.sum(j_0 * j_0, 1),
            np.sum(j_0 * j_1, 1),
            np.sum(j_1 * j_1, 1),
            np.sum(j_0 * residual, 1),
            np.sum(j_1 * residual, 1),
        ],
        axis=1,
    )
    scale = np.maximum(reference[:, 0], reference[:, 2])  # |J|^2, and |J| |r| for J^T r
    size = np.stack([scale] * 3 + [np.sqrt(scale * cost)] * 2, axis=1)
    error = np.abs(products[:, :5] - reference) / size
    close = (error < 1e-4).all(axis=1)
    assert close.mean() > 0.9, (close.mean(), np.median(error, axis=0))
    assert np.median(error) < 1e-6, np.median(error, axis=0)


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_start_fits_keep_the_products_a_refit_gives(glossy, name):
    """``J^T J`` and ``J^T r`` that :func:`best_start` keeps from the winner's fit and
    :func:`fit_pixels` from its fits equal those :func:`lm_step` computes by refitting the
    normal (what its first iteration did before), and the active sets are the refit's: the
    same numbers."""
    gray, lights, lit, starts, _ = glossy
    basis, nonnegative = _basis(name)
    g, w = np.ascontiguousarray(gray.T), np.ascontiguousarray(lit)
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    n_pixels, k = len(g), basis.size

    def refit_products(normals, free):
        products = np.zeros((n_pixels, 6))
        active = np.ones(n_pixels, dtype=bool)
        _bivariate_stereo_kernels.lm_step(
            np.array(normals), np.full(n_pixels, 1e-3), np.empty(g.shape), np.empty(n_pixels),
            active, free, g, w, *inputs, nonnegative, np.inf, products,
        )  # fmt: skip
        assert not active.any()  # every pixel refitted, none stepped
        return products

    normals, residual, cost = np.empty((n_pixels, 3)), np.empty(g.shape), np.empty(n_pixels)
    free, kept = np.ones((n_pixels, k), dtype=bool), np.zeros((n_pixels, 6))
    _bivariate_stereo_kernels.best_start(
        starts, bivariate_stereo.BEST_START_RING, g, w, *inputs, nonnegative, normals, residual,
        cost, free, np.empty((n_pixels, k)), True, kept,
    )  # fmt: skip
    assert (kept[:, 5] == 1).all()
    refit_free = free.copy()
    reference = refit_products(normals, refit_free)
    np.testing.assert_array_equal(kept, reference)
    np.testing.assert_array_equal(free, refit_free)

    moved = starts[1] + 0.05
    moved /= np.linalg.norm(moved, axis=1, keepdims=True)
    free, kept = np.ones((n_pixels, k), dtype=bool), np.zeros((n_pixels, 6))
    _bivariate_stereo_kernels.fit_pixels(
        moved, g, w, *inputs, nonnegative, np.empty(g.shape), np.empty((n_pixels, k)), free, kept
    )
    reference = refit_products(moved, free.copy())
    np.testing.assert_array_equal(kept, reference)


@pytest.mark.parametrize("n_lights", [3, 4, 10, 11, 96, 100])
def test_order_statistics_equal_numpy_sort_and_percentile(glossy, n_lights):
    rng = np.random.default_rng(7)
    if n_lights == 96:
        gray = glossy[0]
    else:
        gray = rng.random((n_lights, 300))
    gray = np.concatenate([gray, np.round(gray[:, :60], 1), np.zeros((n_lights, 3))], axis=1)
    gray[:2, -2] = 0.5  # ties above the shadows, an all-dark pixel
    for threshold in (0.0, 0.05, 0.5):
        ranks, lit, by_pixel = bivariate_stereo._order(gray, threshold)
        ref_ranks, ref_lit = bivariate_reference.order(gray, threshold)
        np.testing.assert_array_equal(ranks, ref_ranks)  # ties by NumPy's order
        np.testing.assert_array_equal(lit, ref_lit)
        np.testing.assert_array_equal(by_pixel, gray.T)
        assert by_pixel.flags.c_contiguous and ranks.dtype == ref_ranks.dtype
    with pytest.raises(bivariate_stereo.ParameterError):
        bivariate_stereo._order(gray, 1.0)


def test_ramps_bound_equals_the_unconstrained_fit(glossy):
    # the Cholesky bound against _fit's unconstrained cost (LU solve, residual pass) on the
    # same observations: equal up to the rounding of the two solves (the Grams of normals far
    # off are ill-conditioned: ~1e-12 of the signal), a thousandth of the screening margin
    gray, lights, lit, starts, _ = glossy
    basis = bivariate_stereo._sum_of_lobes_basis(*_ramps_knots())
    inputs = bivariate_stereo._kernel_inputs(lights, basis)
    n_lights, k = len(lights), basis.size
    kept = np.empty(n_lights, np.int64)
    g_kept, w_kept = np.empty(n_lights), np.empty(n_lights)
    scratch = _bivariate_stereo_kernels._scratch(n_lights, k)
    rng = np.random.default_rng(8)
    normals = starts[1] + rng.normal(scale=0.2, size=starts[1].shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    for n, g, w in zip(normals, gray.T, lit, strict=True):
        m = _bivariate_stereo_kernels._kept(w, g, kept, g_kept, w_kept)
        for stride in (1, 3):
            sub = np.arange(0, m, stride)
            sk, sg, sw = kept[sub].copy(), g_kept[sub].copy(), w_kept[sub].copy()
            bound = _bivariate_stereo_kernels._ramps_bound(
                *n, sk, sg, sw, len(sub), lights, inputs[1], basis.fa, basis.fb, scratch
            )
            cost = _bivariate_stereo_kernels._fit(
                *n, sk, sg, sw, len(sub), *inputs, False, np.empty(n_lights), np.empty(k),
                np.ones(k, dtype=bool), scratch,
            )  # fmt: skip
            signal = np.sum(sw * sg**2)
            margin = _bivariate_stereo_kernels.SCREEN_MARGIN * signal
            assert abs(bound - cost) <= 1e-3 * margin, (bound, cost, signal)


def test_pair_solve_equals_two_solves():
    rng = np.random.default_rng(9)
    for k in (2, 5, 14):
        for _ in range(20):
            a = rng.standard_normal((k + 3, k))
            gram = a.T @ a
            gram[0, 0] *= 1e6 if k > 2 else 1.0  # pivoting
            free = rng.random(k) < 0.7
            rhs = rng.standard_normal((2, k))
            pair = np.empty((2, k))
            _bivariate_stereo_kernels._solve_free_sides(
                gram, rhs, free, np.empty((k, k)), np.empty((2, k)), pair
            )
            for side in range(2):
                one = np.empty(k)
                _bivariate_stereo_kernels._solve_free(
                    gram, rhs[side], free, np.empty((k, k)), np.empty(k), one
                )
                np.testing.assert_array_equal(pair[side], one)


def test_table_rows_equal_the_arccos_rows():
    # fdlibm's acos, vectorised, against libm's: the same rows up to the last bit of θ_h; the
    # compiled kernel exactly as its Python source computes (no floating-point licences)
    rng = np.random.default_rng(10)
    cosines = np.concatenate(
        [rng.random(20000), [-0.5, 0.0, 1e-300, 0.5, np.nextafter(0.5, 0), 1.0, 1.5, 0.999999]]
    )
    m = len(cosines)
    for n_h in (2, 5, 24):
        bins, fractions = np.empty((m, 2), np.int64), np.empty((m, 2))
        _bivariate_stereo_kernels._table_rows(cosines, m, n_h, bins, fractions)
        py_bins, py_fractions = np.empty((m, 2), np.int64), np.empty((m, 2))
        with np.errstate(invalid="ignore"):  # at cos θ_h = 1 the unused range divides 0 by 0
            _bivariate_stereo_kernels._table_rows.py_func(cosines, m, n_h, py_bins, py_fractions)
        np.testing.assert_array_equal(bins[:, 0], py_bins[:, 0])
        np.testing.assert_array_equal(fractions, py_fractions)
        theta = np.arccos(np.clip(cosines, 0.0, 1.0))
        root = np.sqrt(theta / (np.pi / 2))
        u = root * (n_h - 1)
        i = np.minimum(np.floor(u).astype(np.int64), n_h - 2)
        ours = fractions[:, 1] ** 2 * (np.pi / 2)
        assert (np.abs(ours - theta) <= 4 * np.spacing(np.maximum(theta, 1e-300))).all()
        np.testing.assert_allclose(fractions[:, 1], root, rtol=4e-16, atol=0)
        same = bins[:, 0] == i  # a node's boundary may fall on either side by a bit
        assert same.mean() > 0.999
        np.testing.assert_allclose(fractions[same, 0], (u - i)[same], rtol=0, atol=1e-14)


@pytest.mark.parametrize("method", ["constrained_bivariate", "bipolynomial"])
def test_the_threads_share_the_pixels_without_changing_a_number(method):
    """The fits and the normal search run in threads of their own (``_over_threads``), every
    pixel on its own: one thread gives the same normals, bit for bit, as two. (Not so shared
    bivariate: its table sums over the pixels, in an order the threads set.)"""
    import numba

    normals, mask = photometric_stereo.sphere_normals((40, 40), (19.5, 19.5), 19.0)
    data = datasets.render_synthetic(
        normals, mask, datasets.diligent_like_lights(), albedo=0.5, specular=0.5,
        shininess=40.0, noise=0.002, rng=np.random.default_rng(2),
    )  # fmt: skip
    solve = bivariate_stereo.METHODS[method]
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        alone = solve(data.images, data.light_directions, data.mask).normals
    finally:
        numba.set_num_threads(threads)
    shared = solve(data.images, data.light_directions, data.mask).normals
    np.testing.assert_array_equal(alone, shared)
