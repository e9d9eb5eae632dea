"""Cornell .brdf files: parsing, spectral → sRGB, the resampled table."""

from __future__ import annotations

import math

import numpy as np
import pytest

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
