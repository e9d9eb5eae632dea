"""Out-of-core photometric stereo: tile by tile on a LocalCluster of two worker processes it
equals the in-memory solve; tiled integration equals the global one on an integrable field."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("distributed", reason="needs the dask extra: pip install 'brdfkit[dask]'")
pytest.importorskip("zarr", reason="needs the dask extra: pip install 'brdfkit[dask]'")

import zarr

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.distributed import tiled
from brdfkit.vision import datasets
from brdfkit.vision import photometric_stereo as ps
from brdfkit.vision.normal_integration import least_squares_integration
from brdfkit.vision.synthesis import synthetic_set

runner = CliRunner()


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A glossy sphere with attached shadows (what trimming is for), 70 × 70, 3 × 4 lights."""
    normals, mask = ps.sphere_normals((70, 70), (34.5, 33.0), 30.0)
    lights = datasets.diligent_like_lights(4, 3, np.radians(40))
    spec = "lambertian(rho=[0.6, 0.4, 0.3]) + ggx(alpha=0.25)"
    path = tmp_path_factory.mktemp("ps") / "glossyPNG"
    datasets.save_diligent(synthetic_set(normals, mask, lights, parse(spec)), path)
    return path


@pytest.mark.slow
def test_tiles_on_two_worker_processes_equal_the_in_memory_solve(folder, tmp_path):
    from distributed import Client, LocalCluster

    data = datasets.load_diligent(folder)
    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=50,
        ) as cluster,  # fmt: skip
        Client(cluster) as client,
    ):
        stack = tiled.stage(folder, tmp_path / "stack.zarr", tile=16)
        assert len(client.scheduler_info()["workers"]) == 2
        np.testing.assert_array_equal(zarr.open_array(stack.path)[:], data.images)
        for method in ("least_squares", "trimmed"):
            n_store, a_store = tmp_path / f"{method}-n.zarr", tmp_path / f"{method}-a.zarr"
            tiled.solve(stack, method, n_store, a_store)
            alone = ps.METHODS[method](data.images, data.light_directions, data.mask)
            normals, albedo = zarr.open_array(n_store)[:], zarr.open_array(a_store)[:]
            assert normals.dtype == np.float32 and normals.shape == alone.normals.shape
            np.testing.assert_allclose(normals, alone.normals, rtol=0, atol=3e-7)  # float32
            np.testing.assert_allclose(albedo, alone.albedo, rtol=3e-7, atol=3e-7)
    with pytest.raises(Exception, match="couples pixels"):
        tiled.solve(stack, "robust_pca", tmp_path / "x.zarr", tmp_path / "y.zarr")


def test_tiled_integration_equals_the_global_solve_on_an_integrable_field(tmp_path):
    rows, columns = np.mgrid[0:90, 0:110].astype(float)
    height = 6 * np.exp(-((columns - 40) ** 2 + (rows - 50) ** 2) / 300) + 0.02 * columns
    d_v, d_u = np.gradient(height)  # z towards the camera; rows go down, so y = -row
    normals = np.stack([-d_u, d_v, np.ones_like(height)], axis=-1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    mask = np.ones(height.shape, bool)
    mask[:, 70:73] = False  # two components, one of them cut by tiles
    mask[10:20, 10:20] = False
    store = tmp_path / "n.zarr"
    written = zarr.open_array(store, mode="w", shape=normals.shape, chunks=(32, 32, 3), dtype="f8")
    written[:] = normals
    tiled.integrate(store, mask, tmp_path / "z.zarr", tile=32, overlap=8)
    depth = zarr.open_array(tmp_path / "z.zarr")[:]
    reference = least_squares_integration(normals, mask)
    assert np.array_equal(np.isnan(depth), ~mask)
    assert np.nanmax(np.abs(depth - reference)) < 1e-3 * np.nanmax(reference)


@pytest.mark.slow
def test_ps_chunks_writes_zarr_equal_to_the_in_memory_command(folder, tmp_path):
    memory, tiles = tmp_path / "memory", tmp_path / "tiles"
    base = ["ps", str(folder), "-m", "least_squares", "--json"]
    assert runner.invoke(app, [*base, "-o", str(memory)]).exit_code == 0
    result = runner.invoke(app, [*base, "--chunks", "32", "-o", str(tiles)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["out_of_core"]["tile"] == 32 and summary["angular_error_deg"]["mean"] > 0
    normals = zarr.open_array(tiles / "normals.zarr")[:]
    np.testing.assert_allclose(normals, np.load(memory / "normals.npy"), atol=3e-7)
    depth = zarr.open_array(tiles / "depth.zarr")[:]
    assert np.array_equal(np.isnan(depth), ~datasets.load_diligent(folder).mask)
    again = runner.invoke(app, [*base, "--chunks", "32", "-o", str(tiles)])
    assert again.exit_code == 0  # its own earlier outputs are replaced
    (tmp_path / "foreign" / "normals.zarr").mkdir(parents=True)
    (tmp_path / "foreign" / "normals.zarr" / "notes").write_text("mine")
    refused = runner.invoke(app, [*base, "--chunks", "32", "-o", str(tmp_path / "foreign")])
    assert refused.exit_code == 2 and "normals.zarr" in refused.output
    assert (tmp_path / "foreign" / "normals.zarr" / "notes").read_text() == "mine"
