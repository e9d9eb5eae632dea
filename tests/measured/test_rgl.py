"""RGL .bsdf tensor files: the parser and agreement with Mitsuba 3's measured plugin."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.measured import read_rgl, read_tensor_file


@pytest.fixture(scope="module")
def felt(shared_data):
    return shared_data / "measured" / "rgl" / "acrylic_felt_green_rgb.bsdf"


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_tensor_file_fields(felt):
    fields = read_tensor_file(felt)
    assert fields["rgb"].shape == (1, 8, 3, 32, 32)
    assert fields["vndf"].dtype == np.float32
    assert read_rgl(felt).channels == 3


def test_matches_mitsuba_measured_plugin(felt):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    reference = mi.load_dict({"type": "measured", "filename": str(felt)})
    ours = read_rgl(felt)
    wi, wo = _directions(400, 1), _directions(400, 2)
    f = ours.eval(wi, wo)
    ctx = mi.BSDFContext()
    expected = np.empty_like(f)
    for k in range(len(wi)):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*wo[k])  # Mitsuba's wi is brdfkit's wo (towards the viewer)
        value = np.array(reference.eval(ctx, si, mi.Vector3f(*wi[k])))
        expected[k] = value / wi[k, 2]  # Mitsuba returns f·cos θ of its wo (our wi)
    # Mitsuba computes in float32 (relative ~1e-6); grazing pairs amplify it through 1/cos
    np.testing.assert_allclose(f, expected, rtol=2e-5, atol=1e-6)


def test_zero_below_the_surface_and_torch(felt):
    brdf = read_rgl(felt)
    wi, wo = _directions(50, 3), _directions(50, 4)
    below = wi * [1, 1, -1]
    np.testing.assert_array_equal(brdf.eval(below, wo), 0.0)
    torch = pytest.importorskip("torch")
    f_t = brdf.eval(torch.tensor(wi), torch.tensor(wo))
    np.testing.assert_allclose(f_t.numpy(), brdf.eval(wi, wo), rtol=1e-12)


def test_bad_tensor_files(felt, tmp_path):
    raw = felt.read_bytes()
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(b"not_a_tensor" + raw[12:])
    with pytest.raises(ValueError, match=r"bad\.bsdf.*tensor_file"):
        read_tensor_file(bad)
    bad.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match="truncated"):
        read_tensor_file(bad)
    bad.write_bytes(raw[:40])
    with pytest.raises(ValueError, match="truncated"):
        read_tensor_file(bad)
