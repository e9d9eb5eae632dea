"""An environment map's tables: the irradiance table against its direct quadrature, and the
cache that shares tables between maps of equal pixels."""

import math

import numpy as np
import pytest

from brdfkit.light import EnvironmentMap
from brdfkit.light.environment import (
    IRRADIANCE_CELLS,
    IRRADIANCE_GRID,
    clear_table_cache,
)


def _direct_irradiance_table(image: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The table's quadrature summed over every cell at the flat node indices ``nodes`` (the
    formula of :attr:`EnvironmentMap.irradiance_table`, written out independently)."""
    height, width, channels = image.shape
    rows, cols = IRRADIANCE_CELLS
    edges = np.arange(height + 1) * math.pi / height
    solid_angle = 2 * math.pi / width * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    t, p = np.meshgrid(
        (np.arange(height) + 0.5) * math.pi / height,
        (np.arange(width) + 0.5) * 2 * math.pi / width,
        indexing="ij",
    )
    omega = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    weighted = (omega * solid_angle[:, None, None]).reshape(-1, 3)
    cell = (np.arange(height) * rows // height)[:, None] * cols + np.arange(width) * cols // width
    cell = cell.ravel()

    def moments(values: np.ndarray) -> np.ndarray:  # (cells, 3)
        return np.stack([np.bincount(cell, values * w, rows * cols) for w in weighted.T], -1)

    vectors = [moments(np.ones(height * width))]
    vectors += [moments(image[..., c].ravel().astype(float)) for c in range(channels)]
    node_rows, node_cols = IRRADIANCE_GRID
    tn, pn = np.meshgrid(
        np.linspace(0, math.pi, node_rows), np.arange(node_cols) * 2 * math.pi / node_cols,
        indexing="ij",
    )  # fmt: skip
    normals = np.stack([np.sin(tn) * np.cos(pn), np.sin(tn) * np.sin(pn), np.cos(tn)], -1)
    normals = normals.reshape(-1, 3)[nodes]
    sums = [np.maximum(normals @ v.T, 0).sum(1) for v in vectors]
    return math.pi * np.stack(sums[1:], -1) / sums[0][:, None]


@pytest.mark.parametrize("shape", [(100, 250), (24, 40)])
def test_irradiance_table_equals_the_direct_quadrature_over_every_cell(shape):
    """Cells wholly above or below a normal's horizon summed by arcs equal the clamped sum
    over every cell: with a sun, uneven cells (100 × 250 pixels in 48 × 96 cells) and more
    cells than pixels (empty cells)."""
    rng = np.random.default_rng(7)
    image = rng.random((*shape, 3)).astype(np.float32)
    image[shape[0] // 3, shape[1] // 5] = [5e4, 4e4, 3e4]  # a one-texel sun
    clear_table_cache()
    table = EnvironmentMap(image).irradiance_table.reshape(-1, 3)
    nodes = np.concatenate([np.arange(0, table.shape[0], 11), [table.shape[0] - 1]])  # poles too
    np.testing.assert_allclose(table[nodes], _direct_irradiance_table(image, nodes), rtol=2e-5)


def test_maps_of_equal_pixels_share_their_tables_and_others_do_not():
    rng = np.random.default_rng(3)
    image = rng.random((16, 32, 3))
    clear_table_cache()
    first = EnvironmentMap(image)
    again = EnvironmentMap(image.copy(), scale=2.0, rotation=np.diag([1.0, -1.0, -1.0]))
    assert again.irradiance_table is first.irradiance_table
    assert again.compensated._distribution is first.compensated._distribution
    assert again._distribution is first._distribution
    other = image.copy()
    other[5, 7, 1] += 0.25
    normal = np.array([[0.0, 0.0, 1.0]])
    assert not np.array_equal(EnvironmentMap(other).irradiance(normal), first.irradiance(normal))
    assert EnvironmentMap(other)._distribution is not first._distribution
    clear_table_cache()
    assert EnvironmentMap(image)._distribution is not first._distribution
    # scale and rotation are applied on top of the shared map-frame table
    np.testing.assert_allclose(again.irradiance(-normal), 2.0 * first.irradiance(normal), rtol=1e-6)


def test_irradiance_of_some_normals_equals_the_lookup_in_the_whole_table():
    """Only the table's columns the normals read are built: the values are the same."""
    rng = np.random.default_rng(5)
    image = rng.random((24, 48, 3))
    normals = rng.normal(size=(200, 3))
    normals[:, 0] = np.abs(normals[:, 0])  # one side of the map: half the columns
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    clear_table_cache()
    partial = EnvironmentMap(image).irradiance(normals)
    clear_table_cache()
    whole = EnvironmentMap(image)
    _ = whole.irradiance_table
    np.testing.assert_array_equal(partial, whole.irradiance(normals))
