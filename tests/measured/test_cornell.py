"""Cornell .brdf files: parsing, spectral → sRGB, the resampled table."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.errors import FormatError
from brdfkit.measured import read_cornell, read_cornell_samples, spectrum_to_rgb_matrix


@pytest.fixture(scope="module")
def garnet(shared_data):
    return shared_data / "measured" / "cornell" / "garnet_red.brdf"


def test_reads_the_real_file(garnet):
    s = read_cornell_samples(garnet)
    assert s.spectral.shape == (s.wi.shape[0], 31) and s.values.shape == (s.wi.shape[0], 3)
    np.testing.assert_array_equal(s.wavelengths, np.arange(400, 701, 10))
    rows = [line.split() for line in garnet.read_text().splitlines() if line[:1].isdigit()]
    first = next(r for r in rows if len(r) == 35)
    theta_i, phi_i = float(first[0]), float(first[1])
    np.testing.assert_allclose(
        s.wi[0],
        [
            math.sin(theta_i) * math.cos(phi_i),
            math.sin(theta_i) * math.sin(phi_i),
            math.cos(theta_i),
        ],
    )
    np.testing.assert_allclose(s.spectral[0], [float(x) for x in first[4:]])
    rgb = np.maximum(s.spectral @ spectrum_to_rgb_matrix(s.wavelengths), 0)
    np.testing.assert_allclose(s.values, rgb)
    assert np.median(s.values[:, 0]) > 3 * np.median(s.values[:, 2])  # garnet red is red


def test_grey_spectrum_is_grey(tmp_path):
    wl = " ".join(str(w) for w in range(400, 701, 10))
    row = "0.5 0.0 0.5 3.14159 " + " ".join(["0.1"] * 31)
    path = tmp_path / "grey.brdf"
    path.write_text(f"# num wls\n31\n# wls\n{wl}\n# rows\n{row}\n{row}\n")
    s = read_cornell_samples(path)
    np.testing.assert_allclose(s.values, 0.1, atol=1e-4)


def test_table_follows_the_samples(garnet):
    table = read_cornell(garnet)
    s = table.samples
    f = table.eval(s.wi, s.wo)
    valid = s.valid
    corr = np.corrcoef(np.log1p(f[valid].ravel()), np.log1p(s.values[valid].ravel()))[0, 1]
    assert corr > 0.9
    assert table.channels == 3 and table.isotropic


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "wavelength count"),
        ("31\n400 410\n", "rows of 4 angles"),
        ("2\n500 600\n0 0 0 0 1\n", "rows of 4 angles"),
        ("2\n500 600\n0 0 0 x 1 1\n", "non-number"),
    ],
)
def test_bad_files(tmp_path, text, message):
    path = tmp_path / "bad.brdf"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        read_cornell_samples(path)
    assert "bad.brdf" in str(info.value)


WAVELENGTHS = " ".join(str(w) for w in range(400, 701, 10))


def _cornell(rows: list[str], count: str = "31", wavelengths: str = WAVELENGTHS) -> str:
    return f"# num wls\n{count}\n# wls\n{wavelengths}\n# rows\n" + "".join(r + "\n" for r in rows)


def _row(theta_i: float, phi_i: float, theta_s: float, phi_s: float, value: str = "0.1") -> str:
    return f"{theta_i} {phi_i} {theta_s} {phi_s} " + " ".join([value] * 31)


ROWS = [_row(0.1 * k, 0.3 * k, 0.5 - 0.05 * k, -0.2 * k) for k in range(8)]


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        (_cornell(ROWS, "inf"), "'inf' is not a finite number", 2),
        (_cornell(ROWS, "3", "500 600 700"), "at least 6 within", 4),
        (_cornell(ROWS, "31", WAVELENGTHS.replace("450", "450.5")), "whole nanometres", 4),
        (_cornell(ROWS, "31", WAVELENGTHS.replace("450", "nan")), "'nan' is not a finite", 4),
        (_cornell([*ROWS[:3], ROWS[3].replace("0.1", "nan", 1)]), "not a finite number", 9),
        (_cornell([*ROWS[:2], ROWS[2] + " 1e999"]), "'1e999' is not a finite number", 8),
        (_cornell([*ROWS[:4], _row(0.1, 0, 0.2, 0, "-0.5")]), "negative", 10),
        # the largest float: its sRGB sums exceed it (columns of the matrix sum to ~1.0001),
        # whatever order the matrix product adds the terms in
        (_cornell([*ROWS[:4], _row(0.1, 0, 0.2, 0, "1.7976931348623157e308")]), "too large", 10),
        (_cornell(ROWS)[:-40], "rows of 4 angles", 13),
        (_cornell([*ROWS[:2], ROWS[2].rsplit(" ", 1)[0], *ROWS[3:]]), "rows of 4 angles", 8),
    ],
)
def test_bad_values_raise_naming_file_and_line(tmp_path, text, message, line):
    path = tmp_path / "bad.brdf"
    path.write_text(text)
    with pytest.raises(FormatError, match=message) as info:
        read_cornell_samples(path)
    assert info.value.offset == line and f"line {line})" in str(info.value)
    assert str(info.value).startswith(str(path))


def test_non_utf8_raises_naming_the_line(tmp_path):
    path = tmp_path / "bad.brdf"
    path.write_bytes(_cornell(ROWS).encode().replace(b"0.3", b"0\xff3", 1))
    with pytest.raises(FormatError, match="not UTF-8") as info:
        read_cornell_samples(path)
    assert "bad.brdf (line 7)" in str(info.value)


def test_too_few_rows_above_the_surface(tmp_path):
    path = tmp_path / "below.brdf"
    path.write_text(_cornell([_row(2.0, 0, 0.2, 0)] * 5 + ROWS[:3]))
    with pytest.raises(FormatError, match="3 rows have both directions above"):
        read_cornell(path)


def test_samples_spanning_no_volume_resample_by_nearest(tmp_path):
    path = tmp_path / "flat.brdf"  # θi = θs, φi = φs: every sample has θd = 0
    path.write_text(_cornell([_row(0.1 * k, 0, 0.1 * k, 0, str(0.1 * k)) for k in range(1, 9)]))
    table = read_cornell(path, (8, 8, 8))
    f = table.eval(_directions(200, 1), _directions(200, 2))
    assert np.all(np.isfinite(f)) and np.all(f >= 0)


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)
