"""Thin-film iridescence: the Airy reflectance, Belcour & Barla's RGB integration, the model."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import RoughConductor, ThinFilm
from brdfkit.brdf.thin_film import airy_reflectance, belcour_barla_xyz, xyz_to_linear_srgb
from brdfkit.compiled import compile
from brdfkit.data import colorimetry
from brdfkit.fresnel import fresnel_conductor
from brdfkit.geometry import spherical_to_cartesian

WAVELENGTHS = np.arange(380.0, 781.0, 5.0)


def _airy_complex(cos_1, wavelength, d, eta_2, n_3):
    """The textbook Airy reflectance in complex arithmetic (Born & Wolf §1.6.4), air above:
    r = (r12 + r23 e^{iδ}) / (1 + r12 r23 e^{iδ}), δ = 4π η2 d cos θ2 / λ, per polarisation."""
    sin2 = 1 - cos_1**2
    cos_2 = np.sqrt(1 - sin2 / eta_2**2 + 0j)
    cos_3 = np.sqrt(1 - sin2 / n_3**2 + 0j)
    r12 = (
        (cos_1 - eta_2 * cos_2) / (cos_1 + eta_2 * cos_2),
        (eta_2 * cos_1 - cos_2) / (eta_2 * cos_1 + cos_2),
    )
    r23 = (
        (eta_2 * cos_2 - n_3 * cos_3) / (eta_2 * cos_2 + n_3 * cos_3),
        (n_3 * cos_2 - eta_2 * cos_3) / (n_3 * cos_2 + eta_2 * cos_3),
    )
    phase = np.exp(1j * 4 * np.pi * eta_2 * d * cos_2 / wavelength)
    return 0.5 * sum(
        abs((a + b * phase) / (1 + a * b * phase)) ** 2 for a, b in zip(r12, r23, strict=True)
    )


FILMS = [
    (1.33, 1.5 + 0j, 400.0),  # soap-like film on glass
    (1.45, 1.0 + 0j, 300.0),  # free-standing film (air below)
    (2.0, 1.5 + 0j, 150.0),  # TiO2-like coating
    (1.5, 0.27 + 2.8j, 500.0),  # oxide on a metal
    (1.2, 1.5 + 0j, 1000.0),
]


@pytest.mark.parametrize(("eta_2", "n_3", "d"), FILMS)
def test_normal_incidence_reflectance_is_the_exact_airy_formula(eta_2, n_3, d):
    model = ThinFilm(
        alpha=0.2,
        thickness=d,
        film_eta=eta_2,
        eta=np.full(WAVELENGTHS.size, n_3.real),
        k=np.full(WAVELENGTHS.size, n_3.imag),
        wavelengths=WAVELENGTHS,
    )
    ours = model.fresnel_term(np.array([[1.0]]))[0]
    exact = _airy_complex(1.0, WAVELENGTHS, d, eta_2, n_3)
    assert np.max(np.abs(ours - exact)) < 1e-6
    for cos_1 in (0.8, 0.4, 0.05):  # oblique too, to rounding
        ours = airy_reflectance(np.array([[cos_1]]), WAVELENGTHS, d, eta_2, n_3.real, n_3.imag)[0]
        np.testing.assert_allclose(
            ours, _airy_complex(cos_1, WAVELENGTHS, d, eta_2, n_3), atol=1e-12
        )


def test_no_film_is_the_bare_interface():
    """d = 0 (or a film of the outside's index) leaves the base's Fresnel reflectance."""
    cos = np.linspace(0.01, 1, 50)[:, None]
    bare = fresnel_conductor(cos, 0.27, 2.8)
    for film_eta, d in ((1.6, 0.0), (1.0, 350.0)):
        film = airy_reflectance(cos, 550.0, d, film_eta, 0.27, 2.8)
        np.testing.assert_allclose(film, bare, atol=1e-12)


def test_reflectance_is_between_zero_and_one():
    rng = np.random.default_rng(0)
    cos = rng.random((2000, 1))
    value = airy_reflectance(
        cos,
        rng.uniform(380, 780, (2000, 1)),
        rng.uniform(0, 3000, (2000, 1)),
        rng.uniform(1, 3, (2000, 1)),
        rng.uniform(0.1, 4, (2000, 1)),
        rng.uniform(0, 5, (2000, 1)) * (rng.random((2000, 1)) < 0.5),
    )
    assert np.all(value >= 0) and np.all(value <= 1 + 1e-12)


def _cie_rgb(cos_1, d, eta_2, eta_3, k_3):
    """The exact Airy spectrum at 1 nm summed against the CIE 1931 2° CMFs (equal-energy
    illuminant, Y = 1 for a white reflector), in linear sRGB."""
    wavelengths, xyz_bar = colorimetry.observer()
    r = airy_reflectance(np.array([[cos_1]]), wavelengths, d, eta_2, eta_3, k_3)[0]
    xyz = (r[:, None] * xyz_bar).sum(axis=0) / xyz_bar[:, 1].sum()
    return np.array(xyz_to_linear_srgb()) @ xyz


def test_belcour_barla_rgb_matches_the_spectrally_summed_airy_reflectance():
    """Gaussian fits of the CMFs and three Fourier terms: measured 0.031 worst (free-standing
    film at 73°, where the interfaces reflect most and higher orders matter), mostly < 0.01."""
    errors = []
    for cos_1 in (1.0, 0.7, 0.3):
        for d in (0.0, 100.0, 250.0, 400.0, 700.0, 1000.0, 2000.0):
            for eta_2, eta_3, k_3 in ((1.33, 1.5, 0.0), (1.8, 0.2, 3.0), (1.45, 1.0, 0.0)):
                xyz = belcour_barla_xyz(np.array([[cos_1]]), d, eta_2, eta_3, k_3)[0]
                ours = np.array(xyz_to_linear_srgb()) @ xyz
                errors.append(np.max(np.abs(ours - _cie_rgb(cos_1, d, eta_2, eta_3, k_3))))
    assert max(errors) < 0.035, max(errors)
    assert np.median(errors) < 0.01, np.median(errors)


def _xyz_afresh(cos_1, d, eta_2, eta_3, k_3):
    """belcour_barla_xyz with every sensitivity evaluated afresh (the m = 0 term too)."""
    from brdfkit.brdf.thin_film import ORDERS, _sensitivity, film_amplitudes

    polarisations, q2 = film_amplitudes(cos_1, eta_2, eta_3, k_3)
    opd = 2 * q2 * d
    total = 0
    for r12, r23_sq, phi23 in polarisations:
        r12_sq = r12 * r12
        t121 = 1 - r12_sq
        r123_sq = r12_sq * r23_sq
        rs = t121 * t121 * r23_sq / (1 - r123_sq)
        phi2 = (np.pi - np.where(r12 < 0, np.pi, 0.0)) + phi23
        xyz = (r12_sq + rs) * _sensitivity(0 * opd, 0 * opd)
        cm = rs - t121
        r123 = np.sqrt(np.maximum(r123_sq, 0.0))
        for m in range(1, ORDERS + 1):
            cm = cm * r123
            xyz = xyz + cm * 2 * _sensitivity(m * opd, m * phi2)
        total = total + 0.5 * xyz
    return total


def test_shared_sensitivities_are_the_fresh_ones_bit_for_bit():
    """The m = 0 term is a constant and each order's Gaussian envelopes serve both
    polarisations: the same floats as evaluating every sensitivity afresh."""
    cos_1 = np.random.default_rng(7).random((5000, 1))
    cos_1[:3, 0] = [1.0, 1e-9, 0.5]
    for d, eta_2, eta_3, k_3 in ((400.0, 1.33, 1.5, 0.0), (250.0, 1.8, 0.2, 3.0), (0.0, 1.4, 1, 0)):
        with np.errstate(divide="ignore", invalid="ignore"):
            ours = belcour_barla_xyz(cos_1, d, eta_2, eta_3, k_3)
            fresh = _xyz_afresh(cos_1, d, eta_2, eta_3, k_3)
        assert ours.shape == fresh.shape and np.array_equal(ours, fresh, equal_nan=True)


def test_xyz_to_srgb_constants_are_colour_sciences_matrix():
    """The matrix (brdfkit.data.colorimetry's, Python floats for the kernels) is
    colour-science's Bradford-adapted E → sRGB matrix, to rounding."""
    colour = pytest.importorskip("colour")
    white_e = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["E"]
    expected = colour.XYZ_to_RGB(
        np.eye(3), "sRGB", illuminant=white_e, chromatic_adaptation_transform="Bradford"
    ).T
    np.testing.assert_allclose(np.array(xyz_to_linear_srgb()), expected, rtol=1e-13, atol=1e-15)


def test_thin_film_does_not_import_colour_science():
    import os
    import subprocess
    import sys
    from pathlib import Path

    import brdfkit

    source = str(Path(brdfkit.__file__).parents[1])  # this brdfkit, not another installed one
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([source, os.environ.get("PYTHONPATH", "")])}
    code = (
        "import sys, numpy as np\n"
        "from brdfkit.brdf import MODELS\n"
        "m = MODELS['thin_film']()\n"
        "w = np.array([[0.3, 0.1, 0.9]]) / np.linalg.norm([0.3, 0.1, 0.9])\n"
        "m.eval(w, w)\n"
        "print('colour' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    assert out.stdout.strip() == "False"


def test_white_reflector_is_white():
    np.testing.assert_allclose(np.array(xyz_to_linear_srgb()) @ np.ones(3), 1.0, atol=1e-3)


def test_film_free_model_is_the_rough_conductor():
    eta, k = [0.2, 0.9, 1.1], [3.9, 2.4, 2.1]
    film = ThinFilm(alpha=0.3, thickness=0.0, eta=eta, k=k, wavelengths=[650.0, 550.0, 450.0])
    metal = RoughConductor(alpha=0.3, eta=eta, k=k)
    rng = np.random.default_rng(1)
    wi = spherical_to_cartesian(rng.random(300) * 1.5, rng.random(300) * 6)
    wo = spherical_to_cartesian(rng.random(300) * 1.5, rng.random(300) * 6)
    np.testing.assert_allclose(film.eval(wi, wo), metal.eval(wi, wo), rtol=1e-10, atol=1e-14)


def test_colour_shifts_with_thickness_and_angle():
    """The iridescence itself: the hue of the specular colour moves with d and with θ."""
    model = ThinFilm(thickness=300.0, film_eta=1.8)
    rgb_normal = model.fresnel_term(np.array([[1.0]]))[0]
    rgb_grazing = model.fresnel_term(np.array([[0.4]]))[0]
    thicker = ThinFilm(thickness=450.0, film_eta=1.8).fresnel_term(np.array([[1.0]]))[0]
    for other in (rgb_grazing, thicker):
        a, b = rgb_normal / rgb_normal.sum(), other / other.sum()
        assert np.max(np.abs(a - b)) > 0.05


@pytest.mark.parametrize("wavelengths", [None, [450.0, 550.0, 650.0]])
def test_compiled_path_matches_numpy(wavelengths):
    model = ThinFilm(alpha=0.25, thickness=350.0, film_eta=1.6, wavelengths=wavelengths)
    rng = np.random.default_rng(4)
    wi = spherical_to_cartesian(rng.random(400) * 1.55, rng.random(400) * 6)
    wo = spherical_to_cartesian(rng.random(400) * 1.55, rng.random(400) * 6)
    compiled = compile(model, dtype=np.float64)
    np.testing.assert_allclose(compiled.eval(wi, wo), model.eval(wi, wo), rtol=1e-9, atol=1e-14)


@pytest.mark.parametrize("wavelengths", [None, [450.0, 550.0, 650.0]])
@pytest.mark.slow  # XLA compiles the whole model: 5–40 s on 2 busy cores
def test_jax_matches_numpy_with_finite_gradients(wavelengths):
    jax = pytest.importorskip("jax")
    jnp = jax.numpy
    model = ThinFilm(alpha=0.25, thickness=350.0, film_eta=1.6, wavelengths=wavelengths)
    rng = np.random.default_rng(5)
    wi = spherical_to_cartesian(rng.random(64) * 1.5, rng.random(64) * 6)
    wo = spherical_to_cartesian(rng.random(64) * 1.5, rng.random(64) * 6)
    wi_j, wo_j = jnp.asarray(wi, dtype=jnp.float32), jnp.asarray(wo, dtype=jnp.float32)
    value = jax.jit(model.eval)(wi_j, wo_j)  # one compilation, not one per operation
    np.testing.assert_allclose(np.asarray(value), model.eval(wi, wo), rtol=1e-4, atol=1e-6)
    grad = jax.jit(jax.grad(lambda w: model.eval(w, wo_j).sum()))(wi_j)
    assert bool(jnp.all(jnp.isfinite(grad)))
