"""brdfkit.data.colorimetry: colour-science's tables and formulas restated, bound to it.

Every restated function is compared with colour-science where it is installed (the ``colour``
extra, in ``test``); CIEDE2000 also with Sharma, Wu & Dalal's published test data; and a fresh
process with colour-science blocked shows that brdfkit's default paths never import it.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import brdfkit
from brdfkit.data import colorimetry
from brdfkit.fit import delta_e_2000
from brdfkit.fresnel import rgb_from_spectrum
from brdfkit.light import sunsky
from brdfkit.measured import spectrum_to_rgb_matrix

pytestmark = pytest.mark.filterwarnings("ignore:.*(spectral|Aligning).*")  # colour's notes

SHARMA = np.loadtxt(Path(__file__).with_name("sharma_ciede2000.txt"))
OBSERVER = "CIE 1931 2 Degree Standard Observer"
RTOL = 1e-12

WAVELENGTH_SETS = [
    np.arange(400.0, 701.0, 10.0),  # Cornell: 31 every 10 nm
    np.arange(400.0, 451.0, 10.0),  # the fewest Sprague takes
    np.arange(300.0, 901.0, 5.0),  # beyond the observer on both sides
    np.arange(360.0, 831.0, 1.0),  # the observer's own grid
    np.array([350.0, 400, 450, 500, 600, 700, 800, 900]),  # uneven: cubic spline
    np.array([380.0, 390, 405, 430, 470, 520, 580, 650, 720, 790]),
]


@pytest.fixture(scope="module")
def colour():
    return pytest.importorskip("colour")


def _colour_basis(colour, wavelengths: np.ndarray) -> np.ndarray:
    """tabulated.py's former code: colour-science's Cornell spectral → sRGB matrix."""
    basis = colour.MultiSpectralDistributions(np.eye(len(wavelengths)), wavelengths)
    cmfs = colour.MSDS_CMFS[OBSERVER]
    xyz = colour.msds_to_XYZ(basis, cmfs, colour.SDS_ILLUMINANTS["D65"], method="Integration")
    return (xyz / 100.0) @ colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB.T


def test_shipped_tables_are_colour_sciences(colour):
    wavelengths, xyz_bar = colorimetry.observer()
    cmfs = colour.MSDS_CMFS[OBSERVER]
    np.testing.assert_array_equal(wavelengths, cmfs.wavelengths)
    np.testing.assert_array_equal(xyz_bar, cmfs.values)
    aligned_d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(cmfs.shape)
    np.testing.assert_allclose(colorimetry.d65(), aligned_d65.values, rtol=RTOL)
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    np.testing.assert_array_equal(colorimetry.XYZ_TO_LINEAR_SRGB, srgb.matrix_XYZ_to_RGB)
    np.testing.assert_array_equal(colorimetry.LINEAR_SRGB_TO_XYZ, srgb.matrix_RGB_to_XYZ)


@pytest.mark.parametrize(
    "wavelengths", WAVELENGTH_SETS, ids=lambda w: f"{w[0]:g}-{w[-1]:g}/{w.size}"
)
def test_spectrum_to_rgb_matrix_is_colour_sciences(colour, wavelengths):
    ours = spectrum_to_rgb_matrix(wavelengths)
    np.testing.assert_allclose(ours, _colour_basis(colour, wavelengths), rtol=RTOL, atol=1e-15)


def test_rgb_from_spectrum_is_colour_sciences(colour):
    """fresnel.py's former code on random spectra over several ranges and on the metals."""
    cmfs = colour.MSDS_CMFS[OBSERVER]
    rng = np.random.default_rng(7)
    spectra = [
        (np.linspace(300.0, 900.0, 25), rng.uniform(0.1, 5.0, 25)),
        (np.linspace(400.0, 700.0, 7), rng.uniform(0.0, 1.0, 7)),
        (np.array([410.0, 412.5, 500.0, 612.0, 805.0]), rng.uniform(0.5, 3.0, 5)),
    ]
    for wavelengths, values in spectra:
        sd = colour.SpectralDistribution(
            np.interp(cmfs.wavelengths, wavelengths, values), cmfs.wavelengths
        )
        xyz = colour.sd_to_XYZ(sd, cmfs, colour.sd_ones(cmfs.shape), method="Integration") / 100
        rgb = colour.XYZ_to_RGB(xyz, "sRGB", illuminant=None, chromatic_adaptation_transform=None)
        np.testing.assert_allclose(
            rgb_from_spectrum(wavelengths, values), np.maximum(rgb, 0), rtol=RTOL, atol=1e-15
        )


def _colour_sun(colour, turbidity: float, elevation: float) -> np.ndarray:
    """sunsky.py's former ``sun_radiance`` (the CMFs at the sun's 11 wavelengths through
    colour-science, then its sRGB matrix), on sunsky's own irradiance table."""
    table = sunsky._lerp_index(sunsky._datasets()["sun_irradiance"], turbidity - 1)
    index = (math.degrees(elevation) - 2.0) / 3.0
    irradiance = sunsky._lerp_index(table, min(max(index, 0.0), table.shape[0] - 1 - 1e-7))
    cmfs = colour.MSDS_CMFS[OBSERVER]
    xyz_bar = np.array([cmfs[w] if 360 <= w <= 830 else np.zeros(3) for w in sunsky._WAVELENGTHS])
    xyz = np.mean(xyz_bar * irradiance[:, None], axis=0)
    rgb = colour.XYZ_to_RGB(xyz, "sRGB", illuminant=None, chromatic_adaptation_transform=None)
    solid_angle = 2 * math.pi * (1 - math.cos(math.radians(sunsky.SUN_APERTURE / 2)))
    return rgb * sunsky.SPEC_TO_RGB_SUN * sunsky.CIE_Y_NORMALIZATION / solid_angle


@pytest.mark.parametrize(("turbidity", "elevation"), [(1.0, 0.05), (3.0, 0.5), (7.5, 1.2)])
def test_sun_rgb_is_colour_sciences(colour, turbidity, elevation):
    expected = _colour_sun(colour, turbidity, elevation)
    np.testing.assert_allclose(sunsky.sun_radiance(turbidity, elevation), expected, rtol=RTOL)


def test_xyz_e_to_linear_srgb_is_colour_sciences(colour):
    white_e = colour.CCS_ILLUMINANTS[OBSERVER]["E"]
    expected = colour.XYZ_to_RGB(
        np.eye(3), "sRGB", illuminant=white_e, chromatic_adaptation_transform="Bradford"
    ).T
    np.testing.assert_allclose(colorimetry.xyz_e_to_linear_srgb(), expected, rtol=RTOL, atol=1e-15)


def test_delta_e_2000_is_colour_sciences_on_random_colours(colour):
    rng = np.random.default_rng(11)
    a, b = rng.uniform(0.0, 1.0, (2, 500, 3))
    a[:20] = b[:20]  # equal colours
    a[20:40, 1:] = 0.0  # saturated reds against anything
    srgb = colour.RGB_COLOURSPACES["sRGB"]

    def lab(rgb):
        return colour.XYZ_to_Lab(colour.RGB_to_XYZ(rgb, srgb, apply_cctf_decoding=False))

    expected = colour.delta_E(lab(a), lab(b), method="CIE 2000")
    np.testing.assert_allclose(delta_e_2000(a, b), expected, rtol=RTOL, atol=1e-12)
    np.testing.assert_allclose(
        colorimetry.xyz_to_lab(a @ srgb.matrix_RGB_to_XYZ.T), lab(a), rtol=RTOL, atol=1e-12
    )


def test_ciede2000_is_colour_sciences_on_sharmas_pairs(colour):
    expected = colour.delta_E(SHARMA[:, :3], SHARMA[:, 3:6], method="CIE 2000")
    np.testing.assert_allclose(
        colorimetry.ciede2000(SHARMA[:, :3], SHARMA[:, 3:6]), expected, rtol=RTOL
    )


def test_ciede2000_gives_sharmas_published_values():
    """All 34 pairs to the four decimals Sharma, Wu & Dalal print, both ways round."""
    assert SHARMA.shape == (34, 7)
    forward = colorimetry.ciede2000(SHARMA[:, :3], SHARMA[:, 3:6])
    backward = colorimetry.ciede2000(SHARMA[:, 3:6], SHARMA[:, :3])
    np.testing.assert_allclose(forward, SHARMA[:, 6], atol=5e-5, rtol=0)
    np.testing.assert_allclose(backward, forward, rtol=1e-13)


def test_white_maps_to_white():
    """Y = 1 for a perfect reflector; D65's white is sRGB's (1, 1, 1) to the matrix's four
    decimals; a flat spectrum under E is Mitsuba's (1.205, 0.948, 0.909)."""
    xyz = colorimetry.tristimulus(np.ones(471), colorimetry.d65())
    assert xyz[1] == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(colorimetry.XYZ_TO_LINEAR_SRGB @ xyz, 1.0, atol=1e-3)
    np.testing.assert_allclose(colorimetry.xyz_e_to_linear_srgb() @ np.ones(3), 1.0, atol=1e-3)
    np.testing.assert_allclose(
        rgb_from_spectrum([400.0, 700.0], [1.0, 1.0]), (1.205, 0.948, 0.909), atol=5e-4
    )


def test_align_to_observer_keeps_grid_values_fits_quadratics_and_holds_its_ends():
    grid = colorimetry.observer()[0]
    values = np.sin(grid / 40.0)
    np.testing.assert_allclose(colorimetry.align_to_observer(grid, values), values, rtol=1e-12)
    inner = np.arange(400.0, 701.0, 10.0)
    aligned = colorimetry.align_to_observer(inner, inner**2)
    assert np.all(aligned[grid < 400] == aligned[40]) and np.all(
        aligned[grid > 700] == aligned[340]
    )
    inside = (grid >= 420) & (grid <= 680)  # Sprague is exact for cubics away from the ends
    np.testing.assert_allclose(aligned[inside], grid[inside] ** 2, rtol=1e-12)


def test_default_paths_never_import_colour_science(tmp_path):
    """A fresh process with colour-science blocked reads a Cornell file, reduces a spectrum,
    measures ΔE00 and builds a sun and sky: all work, and colour is never imported."""
    cornell = tmp_path / "tiny.brdf"
    wavelengths = " ".join(str(w) for w in range(400, 701, 10))
    rows = [f"{t} 0.0 {t} 3.14159 " + " ".join(["0.1"] * 31) for t in (0.1, 0.3, 0.5, 0.7)]
    cornell.write_text("# a tiny Cornell file\n31\n" + wavelengths + "\n" + "\n".join(rows) + "\n")
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'colour' or name.startswith('colour.'):\n"
        "            raise ImportError('colour-science is blocked')\n"
        "sys.meta_path.insert(0, Block())\n"
        "import numpy as np, brdfkit\n"
        "from brdfkit.measured import read_cornell_samples\n"
        "from brdfkit.fresnel import rgb_from_spectrum\n"
        "from brdfkit.fit import delta_e_2000\n"
        "from brdfkit.light import SunSky\n"
        f"s = read_cornell_samples({str(cornell)!r})\n"
        "assert np.all(np.isfinite(s.values)) and s.values.shape == (4, 3)\n"
        "assert rgb_from_spectrum([400.0, 700.0], [1.0, 1.0]).shape == (3,)\n"
        "assert float(delta_e_2000(np.array([0.5, 0.2, 0.1]), np.array([0.5, 0.25, 0.1]))) > 1\n"
        "from brdfkit.light.sunsky import sun_radiance\n"
        "SunSky(sun_direction=(0.3, 0.2, 0.9))\n"
        "assert np.all(sun_radiance(3.0, 0.5) > 0)\n"
        "assert not any(m == 'colour' or m.startswith('colour.') for m in sys.modules)\n"
        "print('ok')\n"
    )
    source = str(Path(brdfkit.__file__).parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([source, os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
