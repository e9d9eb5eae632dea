"""Photometric stereo out of core, folder to stores (:mod:`brdfkit.distributed.
tiled_reconstruction`): the stores hold the in-memory solve, the error map is the ground
truth's, and the memory budget reads the folder's stack size."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("distributed", reason="needs the dask extra: pip install 'brdfkit[dask]'")
pytest.importorskip("zarr", reason="needs the dask extra: pip install 'brdfkit[dask]'")

import zarr

from brdfkit.distributed import tiled_reconstruction
from brdfkit.distributed.tiled_reconstruction import STORES, reconstruct_tiled, stack_values
from brdfkit.vision import datasets
from brdfkit.vision import photometric_stereo as ps
from brdfkit.vision.metrics import angular_error_map


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A Lambertian sphere, 40 × 44, in the DiLiGenT layout under 12 lights."""
    normals, mask = ps.sphere_normals((40, 44), (21.5, 19.5), 17.0)
    lights = datasets.diligent_like_lights(4, 3, np.radians(30))
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    path = tmp_path_factory.mktemp("ps") / "ballPNG"
    datasets.save_diligent(datasets.render_synthetic(normals, lit, lights, albedo=0.5), path)
    return path


def test_the_stores_hold_the_in_memory_solve(folder, tmp_path):
    stages = []
    surface = reconstruct_tiled(folder, tmp_path, tile=16, progress=stages.append)
    assert stages == [
        "staging the images to Zarr", "least_squares tile by tile (16²)", "integrating tile by tile"
    ]  # fmt: skip
    data = datasets.load_diligent(folder)
    alone = ps.least_squares(data.images, data.light_directions, data.mask)
    assert set(surface.stores) == set(STORES)
    stored = zarr.open_array(str(surface.stores["normals.zarr"]), mode="r")[:]
    np.testing.assert_array_equal(stored, surface.normals)
    np.testing.assert_allclose(surface.normals, alone.normals, rtol=0, atol=3e-7)  # float32
    assert zarr.open_array(str(surface.stores["depth.zarr"]), mode="r").shape == (40, 44)
    truth = datasets.read_normal_gt(folder / "Normal_gt.mat", data.mask)
    expected = angular_error_map(surface.normals.astype(np.float64), truth, data.mask)
    np.testing.assert_array_equal(surface.error_map, expected)
    measures = surface.measures()
    assert measures["out_of_core"] == {"tile": 16, "stack_bytes": 4 * data.images.size}
    assert measures["angular_error_deg"]["mean"] < 0.01


def test_the_memory_budget_reads_the_stack_size(folder, tmp_path, monkeypatch):
    values = datasets.load_diligent(folder).images.size
    assert values == 12 * 40 * 44  # grey images
    assert stack_values(folder) == values
    assert stack_values(tmp_path) is None  # not a DiLiGenT folder
    assert not tiled_reconstruction.exceeds_memory(folder)
    budget = tiled_reconstruction.BYTES_PER_VALUE * values / tiled_reconstruction.MEMORY_SHARE
    monkeypatch.setattr("brdfkit._checks.available_memory", lambda: budget)
    assert not tiled_reconstruction.exceeds_memory(folder)  # just fits
    monkeypatch.setattr("brdfkit._checks.available_memory", lambda: budget - 1)
    assert tiled_reconstruction.exceeds_memory(folder)
