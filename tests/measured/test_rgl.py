"""RGL .bsdf tensor files: the parser and agreement with Mitsuba 3's measured plugin."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from brdfkit.errors import FormatError
from brdfkit.measured import read_rgl, read_tensor_file
from brdfkit.measured.rgl import _DTYPES


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


def _tensor_bytes(fields: dict[str, np.ndarray]) -> bytes:
    """A Mitsuba tensor file holding ``fields`` (the format of the module docstring)."""
    codes = {np.dtype(t): c for c, t in _DTYPES.items()}
    header = b"tensor_file\x00" + struct.pack("<BBI", 1, 0, len(fields))
    size = len(header) + sum(2 + len(k.encode()) + 11 + 8 * v.ndim for k, v in fields.items())
    body, offsets = b"", []
    for v in fields.values():
        offsets.append(size + len(body))
        body += np.ascontiguousarray(v).tobytes()
    for (k, v), offset in zip(fields.items(), offsets, strict=True):
        name = k.encode()
        header += struct.pack("<H", len(name)) + name
        header += struct.pack(f"<HBQ{v.ndim}Q", v.ndim, codes[v.dtype], offset, *v.shape)
    return header + body


def _anisotropic(fields: dict[str, np.ndarray], phi: list[float]) -> dict[str, np.ndarray]:
    """``fields`` repeated over a φi grid ``phi``."""
    out = dict(fields, phi_i=np.asarray(phi, np.float32))
    for key in ("vndf", "luminance", "rgb"):
        out[key] = np.repeat(fields[key], len(phi), axis=0)
    return out


def _changed(fields, key, change):
    array = np.array(fields[key])
    change(array)
    return dict(fields, **{key: array})


@pytest.mark.parametrize(
    ("change", "field", "message"),
    [
        (lambda f: _changed(f, "rgb", lambda a: a.flat.__setitem__(5, np.nan)), "rgb", "finite"),
        (lambda f: _changed(f, "vndf", lambda a: a.flat.__setitem__(9, np.inf)), "vndf", "finite"),
        (lambda f: _changed(f, "rgb", lambda a: a.flat.__setitem__(7, -0.1)), "rgb", "negative"),
        (lambda f: _changed(f, "sigma", lambda a: a.flat.__setitem__(0, 0)), "sigma", "positive"),
        (lambda f: _changed(f, "vndf", lambda a: a[0, 3].fill(0)), "vndf", "zero everywhere"),
        (lambda f: _anisotropic(f, [0.0, 0.0, 3.0]), "phi_i", "increase strictly"),
        (lambda f: _changed(f, "theta_i", lambda a: a.__setitem__(3, a[2])), "theta_i", "strictly"),
        (lambda f: dict(f, jacobian=np.zeros(0, np.uint8)), "jacobian", "one uint8"),
        (lambda f: dict(f, jacobian=np.ones(1, np.float32)), "jacobian", "one uint8"),
        (lambda f: dict(f, theta_i=f["theta_i"].astype(np.float64)), "theta_i", "float32"),
        (lambda f: dict(f, description=np.zeros(3, np.float32)), "description", "uint8"),
        (lambda f: dict(f, ndf=np.ones((1, 1), np.float32)), None, "invalid structure"),
        (lambda f: dict(f, rgb=f["rgb"][:, :, :2]), None, "invalid structure"),
        (lambda f: dict(f, vndf=f["vndf"][:, :5]), None, "invalid structure"),
        (lambda f: dict(f, theta_i=f["theta_i"][:0]), None, "invalid structure"),
        (lambda f: {k: v for k, v in f.items() if k != "ndf"}, None, r"lacks the fields \['ndf'\]"),
    ],
)
def test_bad_fields_raise_naming_file_and_field(felt, tmp_path, change, field, message):
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(_tensor_bytes(change(read_tensor_file(felt))))
    with pytest.raises(FormatError, match=message) as info:
        read_rgl(bad)
    assert info.value.field == field and "bad.bsdf" in str(info.value)


def test_spectra_need_usable_wavelengths(felt, tmp_path):
    fields = read_tensor_file(felt)
    spectral = {k: v for k, v in fields.items() if k != "rgb"}
    spectral["spectra"] = np.repeat(fields["rgb"][:, :, :1], 6, axis=2)
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(_tensor_bytes(spectral))
    with pytest.raises(FormatError, match=r"lacks the fields \['wavelengths'\]"):
        read_rgl(bad)
    spectral["wavelengths"] = np.linspace(400, 402.5, 6, dtype=np.float32)
    bad.write_bytes(_tensor_bytes(spectral))
    with pytest.raises(FormatError, match="whole nanometres") as info:
        read_rgl(bad)
    assert info.value.field == "wavelengths"
    spectral["wavelengths"] = np.linspace(400, 700, 6, dtype=np.float32)
    bad.write_bytes(_tensor_bytes(spectral))
    grey = read_rgl(bad)
    f = grey.eval(_directions(100, 5), _directions(100, 6))
    assert grey.channels == 3 and np.all(np.isfinite(f)) and np.all(f >= 0)


@pytest.mark.parametrize(
    "shape", [(2**63, 2**63), (0, 2**64 - 1), (2**32, 2**32, 2), (1000, 1000, 1000)]
)
def test_huge_declared_shapes_raise_before_allocating(tmp_path, shape):
    header = b"tensor_file\x00" + struct.pack("<BBI", 1, 0, 1)
    header += (
        struct.pack("<H", 3) + b"rgb" + struct.pack(f"<HBQ{len(shape)}Q", len(shape), 10, 0, *shape)
    )
    bad = tmp_path / "huge.bsdf"
    bad.write_bytes(header + bytes(64))
    with pytest.raises(FormatError, match=r"larger than the file|truncated") as info:
        read_tensor_file(bad)
    assert info.value.field == "rgb" and "huge.bsdf" in str(info.value)


def test_field_name_not_utf8(tmp_path):
    raw = _tensor_bytes({"ab": np.zeros(2, np.float32)}).replace(b"ab", b"\xff\xfe", 1)
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(raw)
    with pytest.raises(FormatError, match="not UTF-8"):
        read_tensor_file(bad)


def test_rows_without_mass_evaluate_finite(felt, tmp_path):
    fields = _changed(read_tensor_file(felt), "vndf", lambda a: a[:, :, :64].fill(0))
    path = tmp_path / "half.bsdf"
    path.write_bytes(_tensor_bytes(fields))
    f = read_rgl(path).eval(_directions(4000, 6), _directions(4000, 7))
    assert np.all(np.isfinite(f)) and np.all(f >= 0)


def test_writer_helper_round_trips(felt, tmp_path):
    path = tmp_path / "same.bsdf"
    path.write_bytes(_tensor_bytes(read_tensor_file(felt)))
    wi, wo = _directions(100, 8), _directions(100, 9)
    np.testing.assert_array_equal(read_rgl(path).eval(wi, wo), read_rgl(felt).eval(wi, wo))


@pytest.mark.parametrize("length", [12, 13, 14, 17, 18, 19, 25, 40])
def test_truncated_anywhere_in_the_header(felt, tmp_path, length):
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(felt.read_bytes()[:length])
    with pytest.raises(FormatError, match="truncated") as info:
        read_tensor_file(bad)
    assert "bad.bsdf" in str(info.value)


def test_saturated_spectra_clip_to_the_gamut(felt, tmp_path):
    fields = read_tensor_file(felt)
    spectral = {k: v for k, v in fields.items() if k != "rgb"}
    spectra = np.zeros((*fields["rgb"].shape[:2], 6, *fields["rgb"].shape[3:]), np.float32)
    spectra[:, :, 2] = fields["rgb"][:, :, 1]  # all energy at 520 nm: outside the sRGB gamut
    spectral.update(spectra=spectra, wavelengths=np.linspace(400, 700, 6, dtype=np.float32))
    path = tmp_path / "green.bsdf"
    path.write_bytes(_tensor_bytes(spectral))
    f = read_rgl(path).eval(_directions(200, 10), _directions(200, 11))
    assert np.all(f >= 0) and np.any(f[:, 1] > 0) and np.all(f[:, [0, 2]] == 0)
