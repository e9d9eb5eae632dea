"""MERL .binary files: bit-exact round trip, the reference lookup, tabulation error, bad files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.errors import FormatError
from brdfkit.measured import MERL_SCALE, MERL_SHAPE, TabulatedBRDF, read_merl, write_merl

MODEL = "lambertian(rho=[0.2, 0.3, 0.4]) + ward(kd=0, ks=[0.05, 0.06, 0.07], alpha_x=0.12)"


@pytest.fixture(scope="module")
def merl_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("merl") / "model.binary"
    write_merl(path, parse(MODEL))
    return path


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_file_layout_is_the_published_one(merl_file):
    raw = merl_file.read_bytes()
    assert np.frombuffer(raw[:12], "<i4").tolist() == [90, 90, 180]
    assert len(raw) == 12 + 3 * 90 * 90 * 180 * 8
    data = np.frombuffer(raw[12:], "<f8").reshape(3, 90, 90, 180)
    table = read_merl(merl_file)
    # channel-major: the red block first, each a C-order [θh][θd][φd] array
    np.testing.assert_array_equal(data[1, 10, 20, 30], table.values[10, 20, 30, 1])
    np.testing.assert_array_equal(table.scale, MERL_SCALE)


def test_round_trip_is_bit_exact(merl_file, tmp_path):
    again = tmp_path / "again.binary"
    write_merl(again, read_merl(merl_file))
    assert again.read_bytes() == merl_file.read_bytes()


def test_nodes_hold_the_model(merl_file):
    model, table = parse(MODEL), read_merl(merl_file)
    wi, wo = table.node_directions()
    inner = (slice(1, None), slice(1, None), slice(None))  # θh, θd > 0: φd well defined
    wi, wo = wi[inner].reshape(-1, 3), wo[inner].reshape(-1, 3)
    above = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    np.testing.assert_allclose(
        table.eval(wi[above], wo[above]), model.eval(wi[above], wo[above]), rtol=1e-12
    )


def _brdfread_index(wi: np.ndarray, wo: np.ndarray) -> tuple[int, int, int]:
    """The lookup of MERL's BRDFRead.cpp, written out per sample from the C++ code."""
    from brdfkit.geometry import to_half_diff

    theta_h, _, theta_d, phi_d = (float(a) for a in to_half_diff(wi, wo))
    i = 0 if theta_h <= 0 else min(max(int(math.sqrt(theta_h / (math.pi / 2) * 90 * 90)), 0), 89)
    j = min(max(int(theta_d / (math.pi * 0.5) * 90), 0), 89)
    if phi_d < 0:
        phi_d += math.pi
    k = min(max(int(phi_d / math.pi * 360 / 2), 0), 179)
    return i, j, k


def test_bin_lookup_is_brdfread(merl_file):
    table = read_merl(merl_file)  # interpolation="bin"
    wi, wo = _directions(300, 1), _directions(300, 2)
    values = table.eval(wi, wo)
    expected = [
        table.values[_brdfread_index(a, b)] * MERL_SCALE for a, b in zip(wi, wo, strict=True)
    ]
    np.testing.assert_array_equal(values, np.array(expected))


def test_ggx_like_model_matches_to_the_tabulation_error(merl_file):
    """Linear lookup converges to the model as the grid refines (error falls ~4× per halving)."""
    model = parse(MODEL)
    wi, wo = _directions(20000, 3), _directions(20000, 4)
    f = model.eval(wi, wo)
    fine = TabulatedBRDF(read_merl(merl_file).values, MERL_SCALE, interpolation="linear")
    coarse = TabulatedBRDF.from_brdf(model, (45, 45, 90))

    def error(t):
        return np.sqrt(np.mean((t.eval(wi, wo) - f) ** 2)) / np.sqrt(np.mean(f**2))

    binned = TabulatedBRDF(fine.values, MERL_SCALE, interpolation="bin")
    assert error(fine) < 0.5 * error(coarse)  # second order: ~4× per halving of the bins
    assert error(fine) < 0.5 * error(binned)  # interpolation beats the cell's first node


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda raw: np.array([90, 90, 90], "<i4").tobytes() + raw[12:], "header dimensions"),
        (lambda raw: raw[:-8], "truncated"),
        (lambda raw: raw + b"\0" * 8, "longer than its header"),
        (lambda raw: raw[:6], "truncated"),
    ],
)
def test_bad_files_raise_naming_the_file(merl_file, tmp_path, mutate, message):
    bad = tmp_path / "bad.binary"
    bad.write_bytes(mutate(merl_file.read_bytes()))
    with pytest.raises(ValueError, match=message) as info:
        read_merl(bad)
    assert "bad.binary" in str(info.value)


def test_unmeasured_entries(tmp_path):
    values = np.full((*MERL_SHAPE, 3), 1500.0)
    values[0] = -1.0  # θh bin 0 not measured
    path = write_merl(tmp_path / "holes.binary", TabulatedBRDF(values, MERL_SCALE))
    table = read_merl(path)
    z = np.array([0.0, 0.0, 1.0])
    np.testing.assert_array_equal(table.eval(z, z), [0.0, 0.0, 0.0])
    assert np.array_equal(table.values, values)


def test_write_rejects_non_brdf(tmp_path):
    with pytest.raises(ValueError, match="brdf must be a BRDF"):
        write_merl(tmp_path / "x.binary", np.zeros(3))


@pytest.mark.parametrize("bad_value", [np.nan, np.inf, -np.inf])
def test_non_finite_values_raise_with_their_offset(merl_file, tmp_path, bad_value):
    data = bytearray(merl_file.read_bytes())
    index = 3 * 90 * 180 + 7  # a red value
    data[12 + 8 * index : 12 + 8 * index + 8] = np.float64(bad_value).tobytes()
    bad = tmp_path / "bad.binary"
    bad.write_bytes(bytes(data))
    with pytest.raises(FormatError, match="not finite") as info:
        read_merl(bad)
    assert info.value.offset == 12 + 8 * index and info.value.field == "values"
    assert "bad.binary" in str(info.value) and f"byte {12 + 8 * index}" in str(info.value)


@pytest.mark.parametrize("bad_value", [1e308, -1e16])
def test_values_that_would_overflow_a_fit_raise_naming_file_and_entry(
    merl_file, tmp_path, bad_value
):
    """A 1e308 entry was read, and ``fit`` printed ``rmse inf``, ``relative_l2 nan``."""
    data = bytearray(merl_file.read_bytes())
    index = 2 * 90 * 90 * 180 + (3 * 90 + 4) * 180 + 5  # blue, θh bin 3, θd bin 4, φd bin 5
    data[12 + 8 * index : 12 + 8 * index + 8] = np.float64(bad_value).tobytes()
    bad = tmp_path / "huge.binary"
    bad.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=r"huge\.binary.*exceeds.*entry B\[3, 4, 5\]"):
        read_merl(bad)


def test_write_refuses_what_read_would_refuse(tmp_path):
    from brdfkit.errors import ParameterError
    from brdfkit.measured import MERL_SCALE, TabulatedBRDF

    values = np.zeros((90, 90, 180, 3))
    values[0, 0, 0, 0] = np.nan
    nan_table = TabulatedBRDF(values, scale=MERL_SCALE, name="nan")
    with pytest.raises(ParameterError, match="not finite"):
        write_merl(tmp_path / "nan.binary", nan_table)
    assert not (tmp_path / "nan.binary").exists()


@pytest.mark.parametrize(
    "dims", [(2**31 - 1, 2**31 - 1, 2**31 - 1), (-90, 90, 180), (90, 180, 90), (0, 0, 0)]
)
def test_wrong_or_huge_dimensions_raise_format_error(merl_file, tmp_path, dims):
    bad = tmp_path / "bad.binary"
    bad.write_bytes(np.array(dims, "<i4").tobytes() + merl_file.read_bytes()[12:100])
    with pytest.raises(FormatError, match="header dimensions") as info:
        read_merl(bad)
    assert info.value.field == "dimensions" and "bad.binary" in str(info.value)


def test_negative_values_read_as_zero_and_are_counted(tmp_path):
    values = np.full((*MERL_SHAPE, 3), 1500.0)
    values[0, :, :, 1] = -1.0  # MERL's "not measured" marker
    values[5, 5, 5, 2] = -0.25
    path = write_merl(tmp_path / "holes.binary", TabulatedBRDF(values, MERL_SCALE))
    table = read_merl(path)
    assert table.clamped == 90 * 180 + 1
    z = np.array([0.0, 0.0, 1.0])
    assert np.all(table.eval(z, z) == 0)  # θh bin 0
    assert write_merl(tmp_path / "again.binary", table).read_bytes() == path.read_bytes()


def test_clamped_is_zero_without_negative_values(tmp_path):
    values = np.full((*MERL_SHAPE, 3), 1500.0)
    path = write_merl(tmp_path / "full.binary", TabulatedBRDF(values, MERL_SCALE))
    assert read_merl(path).clamped == 0
