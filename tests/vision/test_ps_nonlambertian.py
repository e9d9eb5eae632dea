"""Non-Lambertian calibrated photometric stereo (ST14, IA14, AZ08, HM10, WG10 settings): each
beats least squares on glossy spheres, keeps shapes and masks, and names bad input."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import bivariate_stereo, consensus, datasets
from brdfkit.vision.metrics import angular_error
from brdfkit.vision.photometric_stereo import least_squares, sphere_normals

NONLAMBERTIAN = {
    "bipolynomial": bivariate_stereo.bipolynomial,
    "constrained_bivariate": bivariate_stereo.constrained_bivariate,
    "shared_bivariate": bivariate_stereo.shared_bivariate,
    "consensus": consensus.consensus,
}


@pytest.fixture(scope="module")
def glossy():
    """A 40-pixel sphere, Lambertian plus a white Blinn–Phong lobe, 96 DiLiGenT-like lights."""
    size = 40
    normals, mask = sphere_normals((size, size), ((size - 1) / 2, (size - 1) / 2), size / 2.2)
    lights = datasets.diligent_like_lights()
    return datasets.render_synthetic(
        normals,
        mask,
        lights,
        albedo=[0.6, 0.4, 0.3],
        specular=1.0,
        shininess=30.0,
        noise=0.002,
        rng=np.random.default_rng(0),
    )


@pytest.fixture(scope="module")
def baseline(glossy):
    return angular_error(
        least_squares(glossy.images, glossy.light_directions, glossy.mask).normals,
        glossy.normals,
        glossy.mask,
    )


# Measured on this sphere (mean / median °): least squares 10.4 / 6.1, bipolynomial 0.83 / 0.27,
# constrained bivariate 3.4 / 0.96, shared bivariate 0.87 / 0.16, consensus 4.9 / 2.8 (its
# rank order is biased by the highlight, as Higo et al.'s is). Bounds: fractions of least
# squares' mean and median, and the albedo's relative tolerance.
BOUNDS = {
    "bipolynomial": (0.45, 0.15),
    "constrained_bivariate": (0.45, 0.25),
    "shared_bivariate": (0.15, 0.05),
    "consensus": (0.6, 0.65),
}


@pytest.mark.parametrize("name", list(NONLAMBERTIAN))
def test_beats_least_squares_on_a_glossy_sphere(name, glossy, baseline):
    result = NONLAMBERTIAN[name](glossy.images, glossy.light_directions, glossy.mask)
    errors = angular_error(result.normals, glossy.normals, glossy.mask)
    mean_ratio, median_ratio = BOUNDS[name]
    assert baseline["mean"] > 8
    assert errors["mean"] < mean_ratio * baseline["mean"]
    assert errors["median"] < median_ratio * baseline["median"]
    assert result.normals.shape == glossy.normals.shape
    assert result.albedo.shape == (*glossy.mask.shape, 3)
    assert np.all(result.normals[~glossy.mask] == 0)
    np.testing.assert_allclose(np.linalg.norm(result.normals[glossy.mask], axis=1), 1.0)
    # The diffuse albedo comes back through the highlight (per channel, chromaticity kept).
    median_albedo = np.median(result.albedo[glossy.mask], axis=0)
    rtol = 0.15 if name == "consensus" else 0.05
    np.testing.assert_allclose(median_albedo, [0.6, 0.4, 0.3], rtol=rtol)


def test_lambertian_sphere_is_recovered_exactly_enough():
    size = 32
    normals, mask = sphere_normals((size, size), ((size - 1) / 2, (size - 1) / 2), size / 2.2)
    lights = datasets.diligent_like_lights(6, 4, np.radians(35))
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    data = datasets.render_synthetic(normals, lit, lights, albedo=0.5)
    for name, method in NONLAMBERTIAN.items():
        result = method(data.images, data.light_directions, lit)
        errors = angular_error(result.normals, normals, lit)
        if name == "consensus":
            # Only the order of the 24 intensities is used: every normal of the cell where the
            # cosines keep that order fits (measured 2.2° mean, 1.3° median).
            assert errors["mean"] < 3.0 and errors["median"] < 2.0
            continue
        # Noise-free Lambertian data lies in every model: the search converges to the truth.
        assert errors["mean"] < 0.05, name
        np.testing.assert_allclose(result.albedo[lit], 0.5, rtol=2e-3)


def test_bivariate_methods_run_on_the_blas_threads_they_are_given(glossy, monkeypatch):
    # their NumPy products run on photometric_stereo.BLAS_THREADS threads (a threaded OpenBLAS
    # spinning after them competes with the kernels' threads), and the limit is lifted after
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads():
        return max(info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas")

    seen = []
    order = bivariate_stereo._order

    def spy(*args, **kwargs):
        seen.append(blas_threads())
        return order(*args, **kwargs)

    monkeypatch.setattr(bivariate_stereo, "_order", spy)
    with threadpool_limits(2, user_api="blas"):
        for name in ("bipolynomial", "constrained_bivariate", "shared_bivariate"):
            NONLAMBERTIAN[name](glossy.images[:, 15:23, 15:23], glossy.light_directions)
        assert blas_threads() == 2
    assert seen == [1, 1, 1]


def test_bad_input_is_named():
    images = np.ones((12, 8, 8))
    lights = datasets.diligent_like_lights(4, 3, np.radians(30))
    for method in NONLAMBERTIAN.values():
        with pytest.raises(ValueError, match="at least 3 lights"):
            method(images[:2], lights[:2])
        with pytest.raises(ValueError, match="mask must have shape"):
            method(images, lights, np.ones((8, 9), bool))
        with pytest.raises(ValueError, match="shadow_threshold"):
            method(images, lights, shadow_threshold=1.5)
    for method in (
        bivariate_stereo.bipolynomial,
        bivariate_stereo.constrained_bivariate,
        bivariate_stereo.shared_bivariate,
    ):
        with pytest.raises(ValueError, match="iterations"):
            method(images, lights, iterations=0)
    with pytest.raises(ValueError, match="candidates"):
        consensus.consensus(images, lights, candidates=3)
    with pytest.raises(ValueError, match="lower the degree"):
        bivariate_stereo.bipolynomial(images, lights, degree=(5, 1))
    with pytest.raises(ValueError, match="degree"):
        bivariate_stereo.bipolynomial(images, lights, degree=(-1, 0))
    with pytest.raises(ValueError, match="knots"):
        bivariate_stereo.constrained_bivariate(images, lights, knots=8)
    with pytest.raises(ValueError, match="smoothness"):
        bivariate_stereo.shared_bivariate(images, lights, smoothness=-1.0)


def test_robust_pca_rank_three_is_what_wu_et_al_recover(glossy, baseline):
    from brdfkit.vision.photometric_stereo import robust_pca

    convex = robust_pca(glossy.images, glossy.light_directions, glossy.mask, rank=None)
    ranked = robust_pca(glossy.images, glossy.light_directions, glossy.mask)
    convex_errors = angular_error(convex.normals, glossy.normals, glossy.mask)
    errors = angular_error(ranked.normals, glossy.normals, glossy.mask)
    # Measured: convex program alone 8.3° / 3.8°, rank 3 kept 4.5° / 0.22° (least squares
    # 10.4° / 6.1°): the highlights no longer leak into a 4th-6th singular vector.
    assert errors["mean"] < 0.65 * convex_errors["mean"]
    assert errors["median"] < 0.1 * convex_errors["median"]
    assert errors["median"] < 0.05 * baseline["median"]
    with pytest.raises(ValueError, match="rank"):
        robust_pca(glossy.images, glossy.light_directions, glossy.mask, rank=0)


def test_real_gray_sphere(shared_data):
    from brdfkit.vision.photometric_stereo import calibrate_lights_chrome_sphere

    psm = shared_data / "photometric_stereo" / "psm"
    chrome = datasets.load_psm(psm / "chrome")
    lights = calibrate_lights_chrome_sphere(chrome.images, chrome.mask)
    data = datasets.load_psm(psm / "gray", light_directions=lights, step=4)
    errors = {
        name: angular_error(
            method(data.images, data.light_directions, data.mask).normals, data.normals, data.mask
        )
        for name, method in (("least_squares", least_squares), *NONLAMBERTIAN.items())
    }
    # The gray sphere is nearly matte (I ∝ cos^0.83 on it) and has 12 lights: measured mean /
    # median at step 4, least squares 6.4 / 5.3, shared bivariate 6.7 / 4.9, bipolynomial
    # 14.1 / 10.2 (6 of the 12 observations kept by rank), constrained bivariate 9.0 / 7.3,
    # consensus 12.8 / 9.7. Only the shared table's median gains; the per-pixel models have
    # too many weights for 12 observations.
    assert errors["shared_bivariate"]["median"] < 0.97 * errors["least_squares"]["median"]
    assert errors["shared_bivariate"]["mean"] < 1.1 * errors["least_squares"]["mean"]
