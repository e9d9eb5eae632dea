"""Uncalibrated photometric stereo: the GBR ambiguity, integrability, both cues on a render,
and the real psm gray sphere against its chrome-calibrated lights."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from brdfkit.errors import ParameterError
from brdfkit.vision import datasets
from brdfkit.vision import uncalibrated as unc
from brdfkit.vision.metrics import angular_error
from brdfkit.vision.photometric_stereo import (
    calibrate_lights_chrome_sphere,
    least_squares,
    sphere_normals,
)

# The psm lights' geometry (12 lights within ~45° of the view), fixed here for the render.
LIGHTS = datasets.diligent_like_lights(4, 3, np.radians(30))


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, 1), -1, 1)))


def _render(size: int = 120) -> tuple[np.ndarray, ...]:
    """A Lambertian sphere of two albedos, attached shadows, lights of unequal intensity:
    images, mask, normals, intensities, albedo."""
    normals, mask = sphere_normals((size, size), ((size - 1) / 2, (size - 1) / 2), 0.46 * size)
    albedo = np.where(np.arange(size)[None, :] < size // 3, 0.4, 0.8) * np.ones((size, 1))
    intensity = np.linspace(0.8, 1.2, len(LIGHTS))
    shading = np.clip(np.einsum("kj,hwj->khw", LIGHTS, normals), 0, None)
    images = intensity[:, None, None] * albedo * shading * mask
    return images, mask, normals, intensity, albedo


def test_gbr_transformed_scene_gives_the_same_images():
    rng = np.random.default_rng(3)
    b = rng.normal(size=(50, 3))
    k = unc.gbr_matrix(0.3, -0.7, 1.8)
    lights_gbr = LIGHTS @ np.linalg.inv(k)  # rows of K^{-T} l
    np.testing.assert_allclose((b @ k.T) @ lights_gbr.T, b @ LIGHTS.T, rtol=1e-12, atol=1e-12)
    with pytest.raises(ParameterError, match="lambda"):
        unc.gbr_matrix(0.0, 0.0, 0.0)


def test_integrability_leaves_exactly_a_gbr():
    images, mask, normals, _, albedo = _render()
    gray = images[:, mask]
    lit = unc.lit_everywhere(gray)
    _, b_hat = unc.factorize(gray[:, lit])
    valid = np.zeros(mask.shape, bool)
    valid.flat[np.flatnonzero(mask)[lit]] = True
    e_map = np.zeros((*mask.shape, 3))
    e_map[valid] = b_hat.T
    a = unc.integrability_transform(e_map, valid)
    truth = (normals[valid] * albedo[valid][:, None]).T
    k = truth @ np.linalg.pinv(b_hat) @ np.linalg.inv(a)  # A_true A^{-1}: a GBR up to scale
    k /= k[2, 2]
    # A GBR has a zero bottom row and equal diagonal (central differences: 1e-3 level here).
    assert np.abs(k[2, :2]).max() < 0.01
    assert abs(abs(k[0, 0]) - abs(k[1, 1])) < 0.02 * abs(k[0, 0])
    assert abs(k[0, 1]) < 0.01 and abs(k[1, 0]) < 0.01


@pytest.mark.parametrize("cue", ["diffuse_maxima", "entropy"])
def test_both_cues_recover_lights_and_normals_of_a_render(cue):
    images, mask, normals, intensity, _ = _render()
    estimate = unc.uncalibrated(images, mask, cue=cue)
    errors = _angles(estimate.light_directions, LIGHTS)
    # Measured 0.02-0.05° median (the residue of discretising integrability on a 55 px sphere).
    assert np.median(errors) < 0.3
    assert errors.max() < 1.0
    np.testing.assert_allclose(
        estimate.light_intensities, intensity / np.median(intensity), rtol=0.02
    )
    lit = mask & np.all(normals @ LIGHTS.T > 0, axis=-1)
    assert angular_error(estimate.result.normals, normals, lit)["median"] < 0.3


def _glossy_gbr_sphere(size: int = 48) -> tuple[np.ndarray, ...]:
    """A glossy (Lambertian + Blinn-Phong) rendering of the GBR-transformed sphere
    ``0.7 z + 0.3 x - 0.2 y``: images, mask, normals, lights. Its Lambertian part alone is
    explained as well by the plain sphere under other lights (the bas-relief ambiguity)."""
    lights = datasets.diligent_like_lights(6, 4, np.radians(40))
    sphere, mask = sphere_normals((size, size), ((size - 1) / 2, (size - 1) / 2), 0.45 * size)
    normals = np.einsum("ij,hwj->hwi", unc.gbr_matrix(0.3, -0.2, 0.7), sphere)
    normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)
    normals = np.where(mask[..., None], normals, 0.0)
    rng = np.random.default_rng(1)
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=0.5, specular=0.3, shininess=400, noise=0.002, rng=rng
    )
    return data.images, mask, normals, lights


def test_specular_cue_recovers_a_gbr_transformed_glossy_sphere():
    images, mask, normals, lights = _glossy_gbr_sphere()
    estimate = unc.uncalibrated(images, mask, cue="specular", method="trimmed")
    errors = _angles(estimate.light_directions, lights)
    # Measured 0.07° median, 0.12° at most; the Lambertian reading of the same images (the
    # plain sphere under the lights K^T l) is 6° from these lights.
    assert np.median(errors) < 0.5 and errors.max() < 1.0
    assert np.median(_angles(lights @ unc.gbr_matrix(0.3, -0.2, 0.7), lights)) > 5.0
    assert estimate.gbr is None and estimate.cue == "specular"
    np.testing.assert_allclose(estimate.light_intensities, 1.0, atol=0.01)
    assert angular_error(estimate.result.normals, normals, mask)["median"] < 1.0  # 0.25°


def test_integrable_view_rotation_is_not_led_by_the_rim():
    """A sphere's normals turned by 25° about the view, the three outer pixels' by a further
    15° (what a non-Lambertian rim does to the factor): integrability finds the 25°."""
    from scipy import ndimage

    normals, mask = sphere_normals((90, 90), (44.5, 44.5), 40.0)
    rim = mask & (ndimage.distance_transform_edt(mask) <= 3)
    turn = np.where(rim, np.radians(40.0), np.radians(25.0))
    xy = (normals[..., 0] + 1j * normals[..., 1]) * np.exp(1j * turn)
    turned = np.stack([xy.real, xy.imag, normals[..., 2]], axis=-1)
    phi, non_integrability = unc.integrable_view_rotation(turned, mask)
    # Measured: 0.002° off the turn back (mod 180°: the depth-reversed field is as
    # integrable), the residual 0.12 of the field turned 90° further (0.002 without the rim's
    # turn).
    assert abs((np.degrees(phi) + 25.0 + 90.0) % 180.0 - 90.0) < 0.3
    assert non_integrability < 0.2
    # A mirror image is integrable at no turn (measured 0.98).
    mirrored = turned * np.array([-1.0, 1.0, 1.0])
    assert unc.integrable_view_rotation(mirrored, mask)[1] > 0.5


def test_specular_cue_on_a_measured_acrylic_sphere(shared_data):
    """The Cornell acryl_blue paint on a sphere under DiLiGenT's lights: its rim departs from
    Lambert's law, and the rim's normals turn the lights 6.7° off (median, measured);
    integrability turns them to within 3.2° (measured), what the metric of equal intensities
    leaves."""
    from brdfkit.measured import read
    from brdfkit.vision.synthesis import render_brdf

    brdf = read(shared_data / "measured" / "cornell" / "acryl_blue.brdf")
    normals, mask = sphere_normals((96, 96), (47.5, 47.5), 40.0)
    lights = datasets.diligent_like_lights()
    images = render_brdf(normals, mask, lights, brdf).mean(axis=-1)
    images /= images.max()
    estimate = unc.uncalibrated(images, mask, cue="specular")
    assert estimate.cue == "specular"
    assert np.median(_angles(estimate.light_directions, lights)) < 4.5


def test_specular_cue_is_refused_without_highlights_and_auto_falls_back():
    images, mask, *_ = _render(60)
    with pytest.raises(ParameterError, match="specular highlights in 0 images"):
        unc.uncalibrated(images, mask, cue="specular")
    assert unc.uncalibrated(images, mask).cue == "entropy"
    glossy, glossy_mask, *_ = _glossy_gbr_sphere(40)
    assert unc.uncalibrated(glossy, glossy_mask).cue == "specular"


def test_robust_factorization_leaves_highlights_out():
    images, mask, _, lights = _glossy_gbr_sphere()
    gray = images[:, mask].mean(axis=-1)
    lit = gray > 0.05 * np.percentile(gray, 99, axis=1)[:, None]
    factor = unc.robust_factorize(gray, lit)

    # The factor is the true lights up to a linear map: the best one leaves 0.015° (measured)
    # of the robust factor, 0.57° of the plain rank-3 SVD of the same images.
    def best_linear_error(lights_hat: np.ndarray) -> float:
        best = lights_hat @ np.linalg.lstsq(lights_hat, lights, rcond=None)[0]
        return float(np.median(_angles(best, lights)))

    assert best_linear_error(factor.lights) < 0.1
    assert best_linear_error(unc.factorize(gray)[0]) > 0.3
    assert factor.known.all() and factor.residual[lit].max() > 50 * factor.noise
    assert len(unc.specular_highlights(factor, gray, lit)[0]) == len(lights)


def test_convex_sign_is_chosen():
    images, mask, normals, _, _ = _render()
    estimate = unc.uncalibrated(images, mask)
    lit = mask & np.all(normals @ LIGHTS.T > 0, axis=-1)
    concave = estimate.result.normals * np.array([-1.0, -1.0, 1.0])
    # The concave reading flips n_x and n_y: twice the polar angle off, tens of degrees.
    assert angular_error(estimate.result.normals, normals, lit)["median"] < 1.0
    assert angular_error(concave, normals, lit)["median"] > 20.0


def test_bad_input_is_named():
    images, mask, *_ = _render(40)
    with pytest.raises(ParameterError, match="cue"):
        unc.uncalibrated(images, mask, cue="brightness")
    with pytest.raises(ParameterError, match="method"):
        unc.uncalibrated(images, mask, method="magic")
    one_pixel_each = np.zeros_like(images)  # every image lights one pixel of its own
    rows, columns = np.nonzero(mask)
    one_pixel_each[np.arange(len(images)), rows[: len(images)], columns[: len(images)]] = 1.0
    for cue in ("auto", "entropy"):
        with pytest.raises(ParameterError, match="lit in 6 or more images"):
            unc.uncalibrated(one_pixel_each, mask, cue=cue)
        with pytest.raises(ParameterError, match=r"images 1, 2, .* are black inside the mask"):
            unc.uncalibrated(np.zeros_like(images), mask, cue=cue)
    brighter_off_axis = LIGHTS / LIGHTS[:, 2:] ** 4  # no GBR makes these equal
    with pytest.raises(ParameterError, match="equal intensity"):
        unc.resolve_gbr_equal_intensity(brighter_off_axis)
    with pytest.raises(ParameterError, match="at least 6 lights"):
        unc.resolve_gbr_equal_intensity(LIGHTS[:5])
    with pytest.raises(ParameterError, match="rank below 3"):
        unc.factorize(np.outer(np.ones(5), np.arange(1.0, 30.0)))


def test_equal_intensity_gbr_is_exact():
    k = unc.gbr_matrix(-0.4, 0.25, 0.6)
    seen = LIGHTS @ k  # rows of K^T l: the lights of the GBR-transformed family
    np.testing.assert_allclose(unc.resolve_gbr_equal_intensity(seen), (-0.4, 0.25, 0.6))
    # Lights of unequal intensity are not made equal by any GBR: the cue reads them wrong.
    unequal = seen * np.linspace(0.8, 1.2, len(LIGHTS))[:, None]
    assert not np.allclose(unc.resolve_gbr_equal_intensity(unequal), (-0.4, 0.25, 0.6), atol=0.05)


def _matte_diligent(folder, step: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A DiLiGenT object's real normals and depth (every ``step``-th pixel), matte, under
    DiLiGenT's 96 lights with cast shadows, exposed as a camera would (the brightest 1 % of
    the observations clip): images, mask, lights."""
    gt = datasets.load_normal_integration(folder)
    normals, mask, depth = (a[::step, ::step] for a in (gt.normals, gt.mask, gt.depth))
    lights = datasets.diligent_like_lights()
    pixel_size = np.nanmean(depth) / gt.camera[0, 0] * step
    lit = datasets.cast_shadows(-np.where(mask, depth, np.nan), lights, pixel_size)
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=0.6, lit=lit, noise=0.005, rng=np.random.default_rng(0)
    )
    images = np.clip(data.images / np.percentile(data.images[:, mask], 99), 0.0, 1.0)
    return images, mask, lights


@pytest.mark.parametrize("cue", ["equal_intensity", "entropy"])
def test_integrable_cues_under_wide_lights_and_cast_shadows(shared_data, cue):
    """Few of the bear's pixels are lit and unsaturated in every image, in patches too small
    for the integrability derivatives, so the pseudo-normals come from the robust
    factorisation of every pixel."""
    images, mask, lights = _matte_diligent(shared_data / "normal_integration/diligent/bear", 4)
    assert unc.lit_everywhere(images[:, mask].mean(axis=-1)).mean() < 0.1
    estimate = unc.uncalibrated(images, mask, cue=cue, sigma=0.25)
    # Measured 1.09° median (equal_intensity) and 1.13° (entropy); the factorisation of the
    # pixels lit in every image alone (4 % of the mask) refused these images: no pixel of
    # it has four such neighbours.
    assert np.median(_angles(estimate.light_directions, lights)) < 2.5


def test_equal_intensity_refuses_where_integrability_fails(shared_data):
    """pot1's normals leave integrability's best GBR about 20° from the true lights; the
    lights it gives cannot be made of equal intensity (measured spread 48 %), and the cue
    says so rather than returning lights 75° off."""
    images, mask, _ = _matte_diligent(shared_data / "normal_integration/diligent/pot1", 8)
    with pytest.raises(ParameterError, match=r"intensities \d+% apart"):
        unc.uncalibrated(images, mask, cue="equal_intensity", sigma=0.125)


def test_real_gray_sphere_against_chrome_calibration(shared_data):
    psm = shared_data / "photometric_stereo" / "psm"
    chrome = datasets.load_psm(psm / "chrome")
    lights = calibrate_lights_chrome_sphere(chrome.images, chrome.mask)
    gray = datasets.load_psm(psm / "gray", light_directions=lights)
    calibrated = angular_error(least_squares(gray.images, lights, gray.mask).normals,
                               gray.normals, gray.mask)  # fmt: skip
    estimate = unc.uncalibrated(gray.images, gray.mask, cue="entropy")
    errors = _angles(estimate.light_directions, lights)
    found = angular_error(estimate.result.normals, gray.normals, gray.mask)
    # Measured at full resolution: lights 4.25° median (9.1° max); normals 9.07° mean against
    # 6.39° calibrated (1.42x). Integrability is the fragile step on these 8-bit images: its
    # smoothing (sigma = 1 px, the default) was chosen on this sphere, and sigma = 2 px or
    # half resolution give 11-14° light errors (see the module docstring).
    assert np.median(errors) < 5.0
    assert found["mean"] < 1.5 * calibrated["mean"]
    # The default ("auto") finds no specular highlight on this matte sphere: entropy.
    half = datasets.load_psm(psm / "gray", step=2)
    assert unc.uncalibrated(half.images, half.mask, sigma=0.5).cue == "entropy"


def test_cli_uncalibrated_writes_the_estimated_lights(tmp_path):
    from typer.testing import CliRunner

    from brdfkit.cli import app

    _, mask, normals, _, albedo = _render()
    data = datasets.render_synthetic(normals, mask, LIGHTS, albedo=albedo[..., None])
    datasets.save_diligent(data, tmp_path / "spherePNG")
    out = tmp_path / "out"
    args = ["ps", str(tmp_path / "spherePNG"), "--uncalibrated", "-m", "least_squares", "-o"]
    result = CliRunner().invoke(app, [*args, str(out), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["gbr_cue"] == "entropy"  # "auto" on a matte object
    assert summary["light_error_deg"]["median"] < 0.5
    assert np.median(_angles(np.loadtxt(out / "lights.txt"), LIGHTS)) < 0.5
    equal = [*args, str(tmp_path / "equal"), "--gbr-cue", "equal_intensity", "--json"]
    summary = json.loads(CliRunner().invoke(app, equal).output)
    assert summary["gbr_cue"] == "equal_intensity"  # the saved lights are of equal intensity
    assert summary["light_error_deg"]["median"] < 0.5
    bad = CliRunner().invoke(app, [*args, str(tmp_path / "bad"), "--gbr-cue", "shading"])
    assert bad.exit_code != 0 and "--gbr-cue" in bad.output
    assert not (tmp_path / "bad").exists()


def test_cli_uncalibrated_on_a_glossy_object_uses_the_specular_cue(tmp_path):
    from typer.testing import CliRunner

    from brdfkit.cli import app

    _, mask, normals, lights = _glossy_gbr_sphere(40)
    data = datasets.render_synthetic(normals, mask, lights, albedo=0.5, specular=0.3,
                                     shininess=400)  # fmt: skip
    datasets.save_diligent(data, tmp_path / "glossyPNG")
    args = ["ps", str(tmp_path / "glossyPNG"), "--uncalibrated", "-m", "trimmed"]
    result = CliRunner().invoke(app, [*args, "-o", str(tmp_path / "out"), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    # Measured 0.02° (16-bit PNGs); the entropy cue on the same images 3.5°. The normals come
    # from the method asked for (any calibrated one), under the estimated lights.
    assert summary["gbr_cue"] == "specular" and summary["method"] == "trimmed"
    assert summary["light_error_deg"]["median"] < 0.5
    assert summary["angular_error_deg"]["mean"] < 2.0


def test_cli_uncalibrated_names_a_black_image(tmp_path):
    """A light that did not fire (a black image) leaves its direction unknowable: one line
    naming the image, a non-zero exit, nothing written (it used to end on a NaN light)."""
    from typer.testing import CliRunner

    from brdfkit.cli import app

    _, mask, normals, _, albedo = _render(40)
    data = datasets.render_synthetic(normals, mask, LIGHTS, albedo=albedo[..., None])
    images = data.images.copy()
    images[4] = 0.0
    datasets.save_diligent(replace(data, images=images), tmp_path / "spherePNG")
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["ps", str(tmp_path / "spherePNG"), "--uncalibrated",
                                      "-o", str(out)])  # fmt: skip
    assert result.exit_code != 0
    assert "image 5 (counted from 1) is black inside the mask" in result.output
    assert "Traceback" not in result.output
    assert not out.exists()
    calibrated = CliRunner().invoke(app, ["ps", str(tmp_path / "spherePNG"), "-o", str(out)])
    assert calibrated.exit_code == 0, calibrated.output  # with its light given, no harm
