"""The environment map's numba lookups (light/_environment_kernels.py) against the code they
mirror in light/environment.py: the same values on random inputs, float64 to rounding."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("numba")

import numba

from brdfkit import sampling
from brdfkit._array import normalize
from brdfkit.compiled import kernel_tools
from brdfkit.light import EnvironmentMap
from brdfkit.light._environment_kernels import COLUMN_BUCKETS, ROW_BUCKETS, guides
from brdfkit.light.environment import compiled_lookups
from brdfkit.sampling import square_to_uniform_sphere


def _lookups(dtype):
    return compiled_lookups(dtype, kernel_tools)


def _map(seed: int = 1) -> EnvironmentMap:
    """A small rotated map with bright texels (a peaked distribution) and dark ones."""
    image = np.random.default_rng(seed).random((16, 32, 3)) ** 4 * 5
    a, b = 0.7, -0.4
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    return EnvironmentMap(image, scale=1.5, rotation=rz @ rx)


def _rotation(env: EnvironmentMap) -> tuple:
    return tuple(float(v) for v in env.rotation.ravel())


def _directions(n: int, seed: int = 2) -> np.ndarray:
    """Random directions, not unit (the lookups normalise), a few at the poles."""
    rng = np.random.default_rng(seed)
    w = square_to_uniform_sphere(rng.random((n, 2))) * rng.uniform(0.5, 2.0, (n, 1))
    w[:4] = [[0, 0, 1], [0, 0, -2], [1e-9, 0, 1], [0, -1e-12, -1]]
    return w


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_unit_is_normalize(dtype):
    unit = _lookups(dtype).unit
    w = _directions(500).astype(dtype)
    w[4] = 0.0  # the zero vector: divided by float32's tiny, stays 0

    @numba.njit
    def each(w, out):
        for i in range(w.shape[0]):
            out[i, 0], out[i, 1], out[i, 2] = unit(w[i, 0], w[i, 1], w[i, 2])

    out = np.empty_like(w)
    each(w, out)
    np.testing.assert_allclose(out, normalize(w), rtol=4 * np.finfo(dtype).eps, atol=0)


def _coordinates_and_radiance(env, dtype, w):
    """The kernels' map coordinates (x, y, sin θ), pdf and bilinear radiance at ``w``."""
    lookups = _lookups(dtype)
    unit, map_coordinates = lookups.unit, lookups.map_coordinates
    texel_cell, bilinear = lookups.texel_cell, lookups.bilinear
    pdf_texel, solid_angle_pdf = lookups.pdf_texel, lookups.solid_angle_pdf
    image, _, scale, _, _, density, _, _ = lookups.tables(env)
    texels, (height, width, nc) = image.reshape(-1), image.shape
    r = tuple(dtype(v) for v in _rotation(env))

    @numba.njit
    def each(w, coordinates, pdf, radiance):
        cells, weights = np.empty((4, 1), np.int64), np.empty((2, 1), w.dtype)
        for i in range(w.shape[0]):
            ux, uy, uz = unit(w[i, 0], w[i, 1], w[i, 2])
            x, y, sin_theta = map_coordinates(ux, uy, uz, r)
            coordinates[i, 0], coordinates[i, 1], coordinates[i, 2] = x, y, sin_theta
            cells[0, 0], cells[1, 0], cells[2, 0], cells[3, 0], weights[0, 0], weights[1, 0] = (
                texel_cell(x, y, height, width, nc)
            )
            bilinear(texels, cells, weights, 0, scale, radiance[i : i + 1].T)
            texel = pdf_texel(x, y, height, width)
            p_uv = dtype(density[max(texel, 0)]) if texel >= 0 else dtype(0)
            pdf[i] = solid_angle_pdf(p_uv, sin_theta)

    w = w.astype(dtype)
    coordinates, pdf = np.empty((w.shape[0], 3), dtype), np.empty(w.shape[0], dtype)
    radiance = np.empty((w.shape[0], nc), dtype)
    each(w, coordinates, pdf, radiance)
    return coordinates, pdf, radiance


def test_map_coordinates_lookup_and_pdf_equal_the_environment_map():
    env = _map()
    w = _directions(3000)
    coordinates, pdf, radiance = _coordinates_and_radiance(env, np.float64, w)
    x, y, sin_theta = coordinates.T
    ex, ey, theta = env._map_coordinates(normalize(w))
    np.testing.assert_allclose(x, ex, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(y, ey, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(sin_theta, np.sin(theta), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(radiance, env.incident_radiance(np.zeros(3), w), rtol=1e-12)
    np.testing.assert_allclose(pdf, env.pdf(np.zeros(3), w), rtol=1e-11, atol=1e-12)
    c32, pdf32, radiance32 = _coordinates_and_radiance(env, np.float32, w)
    np.testing.assert_allclose(c32[:, :2], np.stack([ex, ey], axis=1), atol=3e-6)
    for found, exact in ((radiance32, radiance), (pdf32, pdf)):  # a texel may flip at an edge
        assert np.mean(np.isclose(found, exact, rtol=1e-4)) > 0.995


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_map_sample_equals_the_environment_maps_sample(dtype):
    """Texels (guide-table search), point in the texel, direction and pdf of the kernel
    against EnvironmentMap.sample on the same uniforms."""
    env = _map()
    lookups = _lookups(dtype)
    sample_texels, sample_point = lookups.sample_texels, lookups.sample_point
    sample_direction, solid_angle_pdf = lookups.sample_direction, lookups.solid_angle_pdf
    _, _, _, marginal, conditional, density, row_guide, col_guide = lookups.tables(env)
    height, width = env.image.shape[:2]
    r = tuple(dtype(v) for v in _rotation(env))
    below_one = 1 - np.finfo(np.float64).eps / 2

    @numba.njit
    def each(a, b, wi, pdf):
        n = a.size
        rows, cols, base = np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)
        sample_texels(a, b, marginal, conditional, row_guide, col_guide, height, width, n,
                      rows, cols, base)  # fmt: skip
        for j in range(n):
            row, col, at = rows[j], cols[j], base[j] + cols[j]
            x, y = sample_point(a[j], b[j], row, col, marginal[row], marginal[row + 1],
                                conditional[at], conditional[at + 1], height, width)  # fmt: skip
            wi[j, 0], wi[j, 1], wi[j, 2], sin_theta = sample_direction(x, y, r)
            pdf[j] = solid_angle_pdf(dtype(density[row * width + col]), sin_theta)

    u = np.random.default_rng(3).random((4000, 2)).astype(dtype)
    a = np.minimum(u[:, 0].astype(np.float64), below_one)
    b = np.minimum(u[:, 1].astype(np.float64), below_one)
    wi, pdf = np.empty((4000, 3), dtype), np.empty(4000, dtype)
    each(a, b, wi, pdf)
    expected = env.sample(np.zeros((4000, 3), dtype), u)
    tolerance = 1e-12 if dtype == np.float64 else 2e-6
    np.testing.assert_allclose(wi, expected.wi, rtol=tolerance, atol=tolerance)
    np.testing.assert_allclose(pdf, expected.pdf, rtol=10 * tolerance, atol=tolerance)


def _map_texels(distribution, a, b, tables):
    """The compiled map sample's rows and columns (``sample_texels``)."""
    n = a.size
    height, width = distribution.shape
    rows, cols, base = (np.empty(n, np.int64) for _ in range(3))
    _lookups(np.float64).sample_texels(
        a, b, distribution._marginal, distribution._conditional, *tables, height, width, n,
        rows, cols, base,
    )  # fmt: skip
    np.testing.assert_array_equal(base, rows * (width + 1))
    return rows, cols


def test_guide_table_map_sample_finds_the_bisection_texels():
    """The guide-table search of a map sample finds the NumPy bisection's row and column
    (sampling._find_interval, Distribution2D.sample's) for every variate: empty rows (the
    first and the last included), empty texels at the start, end and inside rows, variates on
    CDF nodes, 0 and just below 1; and it does so from any guide (only the scan length
    depends on it)."""
    rng = np.random.default_rng(7)
    image = rng.random((24, 40)) ** 3
    image[[0, 5, 6, 11, -1]] = 0.0  # empty rows: flat runs of the marginal
    image[:, [0, 1, 17, 18, 19, -1]] = 0.0  # empty first, inner and last texels of each row
    image[3, 2:30] = 0.0
    image[7, :] = 0.0
    image[7, 20] = 4.0  # a row with one texel
    distribution = sampling.Distribution2D(image)
    marginal, conditional = distribution._marginal, distribution._conditional
    height, width = distribution.shape
    below_one = 1 - np.finfo(np.float64).eps / 2
    n = 20_000
    a, b = rng.random(n), rng.random(n)
    b[: height + 1] = np.minimum(marginal, below_one)  # on the marginal's nodes
    rows_on_nodes = np.flatnonzero(np.diff(marginal) > 0)
    b[height + 1 : 2 * height + 1] = 0.5 * (marginal[rows_on_nodes[0]]
                                            + marginal[rows_on_nodes[0] + 1])  # fmt: skip
    a[height + 1 : 2 * height + 1] = rng.random(height)
    # each row's conditional nodes, with b in that row
    for i, row in enumerate(rows_on_nodes):
        at = slice(1000 + i * (width + 1), 1000 + (i + 1) * (width + 1))
        b[at] = marginal[row] + 0.5 * (marginal[row + 1] - marginal[row])
        a[at] = np.minimum(conditional[row * (width + 1) : (row + 1) * (width + 1)], below_one)
    a[-4:], b[-4:] = [0.0, below_one, 0.0, below_one], [0.0, 0.0, below_one, below_one]
    expected_rows = sampling._find_interval(marginal, np.zeros(n, np.int64), b, height)
    expected_cols = sampling._find_interval(conditional, expected_rows * (width + 1), a, width)
    assert np.all(image[expected_rows, expected_cols] > 0)
    rows, cols = _map_texels(distribution, a, b, guides(distribution, kernel_tools))
    np.testing.assert_array_equal(rows, expected_rows)
    np.testing.assert_array_equal(cols, expected_cols)
    for row_buckets, col_buckets in ((1, 1), (7, 3), (4 * height, 8)):
        random_guides = (
            rng.integers(0, height, row_buckets).astype(np.int32),
            rng.integers(0, width, height * col_buckets).astype(np.int32),
        )
        rows, cols = _map_texels(distribution, a, b, random_guides)
        np.testing.assert_array_equal(rows, expected_rows)
        np.testing.assert_array_equal(cols, expected_cols)


def test_map_tables_and_guides_are_built_once_per_map():
    env = _map()
    distribution = env.compensated._distribution  # the shader's MIS samples the compensated map
    row_guide, col_guide = guides(distribution, kernel_tools)
    height, width = distribution.shape
    assert row_guide.shape == (ROW_BUCKETS * height,)
    assert col_guide.shape == (COLUMN_BUCKETS * width * height,)
    tables = _lookups(np.float32).tables(env.compensated)
    assert tables[-2] is row_guide and tables[-1] is col_guide
    assert tables[0].dtype == np.float32 and tables[2] == np.float32(env.scale)


@pytest.mark.parametrize(("shape", "channels"), [((40, 100), 3), ((20, 30), 3), ((20, 30), 1)])
def test_clamped_sums_kernel_equals_the_numpy_sums(shape, channels):
    """The irradiance table's sums over cells (``environment._clamped_sums``) by the numba
    kernel, on every node column and on scattered ones (a partial table), every sixth node
    row with both poles, with a one-texel sun and with more cells than pixels, for colour
    and grey maps (four and two vectors per cell): equal to the rounding of the NumPy code's
    float32 clamped terms (each errs by about ε₃₂·|v_c|; the kernel's are float64)."""
    from brdfkit.light import environment as env_module
    from brdfkit.light.environment import IRRADIANCE_CELLS, IRRADIANCE_GRID

    rng = np.random.default_rng(9)
    image = rng.random((*shape, channels)).astype(np.float32)
    image[shape[0] // 4, shape[1] // 3] = [3e4, 2e4, 1e4][:channels]
    moments = env_module._cell_moments(image, IRRADIANCE_CELLS)
    bounds = env_module._cell_bounds(shape, IRRADIANCE_CELLS)
    rows, cols = IRRADIANCE_GRID
    theta = np.linspace(0.0, math.pi, rows)[::6]
    for columns in (np.arange(cols), np.array([0, 1, 2, 50, 51, 120, 191])):
        phi = columns * (2 * math.pi / cols)
        expected = env_module._clamped_sums(moments, bounds, theta, phi)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(env_module, "_KERNEL_TOOLS", [kernel_tools])
            found = env_module._node_sums(moments, bounds, theta, phi)
        rounding = 2 * np.finfo(np.float32).eps * np.linalg.norm(moments, axis=-1).sum((0, 1))
        assert np.all(np.abs(found - expected) <= rounding + 1e-12 * np.abs(expected))


@pytest.mark.parametrize("shape", [(40, 100), (20, 30)])
def test_cell_moments_kernel_equals_the_numpy_moments(shape):
    """The irradiance table's cell moments by the numba kernel's one pass over the pixels
    equal the NumPy code's weighted run sums to float64 rounding: uneven cells, and more
    cells than pixels (empty cells, zero moments)."""
    from brdfkit.light import environment as env_module
    from brdfkit.light.environment import IRRADIANCE_CELLS

    image = np.random.default_rng(10).random((*shape, 3)).astype(np.float32) * 50
    expected = env_module._cell_moments(image, IRRADIANCE_CELLS)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(env_module, "_KERNEL_TOOLS", [kernel_tools])
        found = env_module._cell_moments(image, IRRADIANCE_CELLS)
    scale = np.abs(expected).max(axis=(0, 1))  # per vector and axis
    assert np.all(np.abs(found - expected) <= 1e-13 * scale)
    assert np.array_equal(found == 0, expected == 0)


@pytest.mark.parametrize("buckets", [1, 7, 64])
def test_guide_table_is_the_searchsorted_of_each_bucket(buckets):
    """The map's guide tables (``kernel_tools.guide_table``, one walk along each row) hold
    ``searchsorted(row, m / buckets, "right") − 1`` clipped to the row's cells: CDFs with
    flat runs, nodes on bucket edges and padding past the row's ``count + 1`` nodes."""
    rng = np.random.default_rng(11)
    rows, count = 6, 30
    weights = rng.random((rows, count)) ** 4
    weights[rng.random((rows, count)) < 0.3] = 0.0
    weights[:, 0] += 1e-12
    cdf = np.concatenate([np.zeros((rows, 1)), np.cumsum(weights, axis=1)], axis=1)
    cdf /= cdf[:, -1:]
    cdf[::2] = np.maximum.accumulate(np.round(cdf[::2] * buckets) / buckets, axis=1)
    cdf[:, -1] = 1.0
    padded = np.concatenate([cdf, np.ones((rows, 2))], axis=1)
    u = np.arange(buckets) / buckets
    expected = [np.clip(np.searchsorted(row, u, side="right") - 1, 0, count - 1) for row in cdf]
    guide = kernel_tools.guide_table(padded.ravel(), count, buckets, rows)
    np.testing.assert_array_equal(guide, np.concatenate(expected))
