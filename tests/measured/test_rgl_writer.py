"""The RGL writer: its tensor files read back bit for bit, and a tabulated analytic model loads
in Mitsuba 3's ``measured`` plugin (and brdfkit's reader) within 2 % (median) of the model."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import Lambertian, RoughConductor
from brdfkit.errors import ParameterError
from brdfkit.measured import read_rgl, read_tensor_file, write_rgl, write_tensor_file

GOLD = RoughConductor(alpha=0.3, material="Au")


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def gold_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("rgl") / "gold.bsdf"
    return write_rgl(GOLD, path, description="GGX alpha=0.3 gold")


def _median_relative_error(values: np.ndarray, reference: np.ndarray) -> float:
    floor = 1e-3 * reference.max()
    return float(np.median(np.abs(values - reference) / np.maximum(reference, floor)))


def test_tensor_files_read_back_exactly(tmp_path):
    fields = {
        "text": np.frombuffer("é".encode(), dtype=np.uint8).copy(),
        "odd": np.arange(7, dtype=np.float32).reshape(7, 1),
        "grid": np.linspace(-1, 1, 24).reshape(2, 3, 4),
        "flags": np.array([1, 0, 1], dtype=np.int16),
    }
    back = read_tensor_file(write_tensor_file(tmp_path / "t.bsdf", fields))
    assert list(back) == list(fields)
    for name, array in fields.items():
        assert back[name].dtype == array.dtype and back[name].shape == array.shape
        np.testing.assert_array_equal(back[name], array)


def test_the_file_has_the_papers_fields(gold_file):
    fields = read_tensor_file(gold_file)
    assert sorted(fields) == sorted(
        ["description", "theta_i", "phi_i", "ndf", "sigma", "vndf", "luminance", "rgb", "jacobian"]
    )
    assert bytes(fields["description"]).decode() == "GGX alpha=0.3 gold"
    assert fields["phi_i"].shape == (1,) and fields["rgb"].shape[:3] == (1, 16, 3)
    table = read_rgl(gold_file)
    assert table.isotropic and table.channels == 3


@pytest.mark.oracle
def test_mitsuba_measured_plugin_matches_the_model(gold_file):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    bsdf = mi.load_dict({"type": "measured", "filename": str(gold_file)})
    wi, wo = _directions(300, 1), _directions(300, 2)
    ctx, theirs = mi.BSDFContext(), []
    for light, view in zip(wi, wo, strict=True):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, view))  # Mitsuba's wi is brdfkit's wo
        si.sh_frame = mi.Frame3f(mi.Normal3f(0, 0, 1))
        theirs.append(np.array(bsdf.eval(ctx, si, mi.Vector3f(*map(float, light)))) / light[2])
    theirs = np.array(theirs)
    model = GOLD.eval(wi, wo)
    assert _median_relative_error(theirs, model) < 0.02
    np.testing.assert_allclose(read_rgl(gold_file).eval(wi, wo), theirs, rtol=1e-4, atol=1e-6)


def test_brdfkits_reader_matches_the_model(gold_file):
    wi, wo = _directions(2000, 3), _directions(2000, 4)
    assert _median_relative_error(read_rgl(gold_file).eval(wi, wo), GOLD.eval(wi, wo)) < 0.02


def test_grey_models_are_written_as_grey_rgb(tmp_path):
    path = write_rgl(Lambertian(0.4), tmp_path / "grey.bsdf")
    rgb = read_tensor_file(path)["rgb"]
    np.testing.assert_array_equal(rgb[:, :, 0], rgb[:, :, 2])
    wi, wo = _directions(200, 5), _directions(200, 6)
    assert _median_relative_error(read_rgl(path).eval(wi, wo), Lambertian(0.4).eval(wi, wo)) < 0.02


def test_other_channel_counts_are_refused(tmp_path):
    with pytest.raises(ParameterError, match="5 channels"):
        write_rgl(Lambertian([0.1, 0.2, 0.3, 0.4, 0.5]), tmp_path / "x.bsdf")
    assert not any(tmp_path.iterdir())
