"""Camera response calibration by every method of :func:`calibrate_response` on simulated
stacks (a gamma camera with shot, read and quantisation noise)."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.errors import ParameterError
from brdfkit.vision.calibration import merge_hdr
from brdfkit.vision.response import (
    METHODS,
    ResponseCalibration,
    calibrate_response,
    emor_basis,
    inverse_of,
    response_family,
)

TIMES = 2.0 ** np.arange(-5, 1)
MEASURED = slice(1, 255)


def _camera(x: np.ndarray) -> np.ndarray:
    """A filmic-like response with a toe and a shoulder, f(1) = 1 (no member of the family)."""
    return np.tanh(2.2 * x**0.7) / np.tanh(2.2)


def _stack(seed: int = 0, size: int = 48) -> np.ndarray:
    """(P, size, size, 1) codes of log-uniform radiances: full well 10⁴ e⁻, read noise 3 e⁻."""
    rng = np.random.default_rng(seed)
    radiance = np.exp(rng.uniform(np.log(0.02), np.log(30.0), (size, size, 1)))
    images = []
    for t in TIMES:
        electrons = radiance * t * 1e4
        noisy = electrons + rng.normal(0, 1, electrons.shape) * np.sqrt(electrons + 9.0)
        images.append(np.round(255 * _camera(np.clip(noisy / 1e4, 0, 1))).astype(np.uint8))
    return np.array(images)


def _error_percent(inverse: np.ndarray) -> float:
    """RMS over the measuring codes after the best scale, in % of the range of the truth."""
    truth = inverse_of(_camera)[MEASURED]
    estimate = inverse[MEASURED]
    scale = estimate @ truth / (estimate @ estimate)
    return float(100 * np.sqrt(np.mean((scale * estimate - truth) ** 2)))


@pytest.fixture(scope="module")
def stack() -> np.ndarray:
    return _stack()


@pytest.mark.parametrize("method", METHODS)
def test_every_method_recovers_the_inverse_response(stack, method):
    result = calibrate_response(stack, TIMES, method, samples=400, bootstrap=2)
    assert isinstance(result, ResponseCalibration) and result.method == method
    assert result.inverse.shape == result.uncertainty.shape == (256, 1)
    assert result.inverse[-1, 0] == 1.0 and np.all(np.diff(result.inverse[:, 0]) >= 0)
    assert _error_percent(result.inverse[:, 0]) < 0.8, method
    # the bootstrap spread is a real, small, non-zero uncertainty
    assert np.all(np.isfinite(result.uncertainty)) and 0 < result.uncertainty.max() < 0.05
    # the curve merges the stack: radiance up to one scale
    radiance = merge_hdr(stack, TIMES, result.log_inverse())
    assert np.all(np.isfinite(radiance)) and radiance.min() > 0


@pytest.mark.parametrize("method", ["mitsunaga_nayar", "emor"])
def test_the_curve_is_stable_from_few_to_many_samples(stack, method):
    few = calibrate_response(stack, TIMES, method, samples=50, bootstrap=0).inverse[:, 0]
    many = calibrate_response(stack, TIMES, method, samples=2000, bootstrap=0).inverse[:, 0]
    assert np.sqrt(np.mean((few - many)[MEASURED] ** 2)) < 0.005  # 0.5 % of the range


def test_the_emor_basis_spans_its_family():
    """Four components reproduce every curve of the family to 0.2 % of the range (RMS)."""
    family = response_family()
    mean, basis = emor_basis(4)
    coefficients = (family - mean) @ basis.T
    residual = family - mean - coefficients @ basis
    assert np.sqrt(np.mean(residual**2)) < 0.002
    assert np.all(basis[:, [0, -1]] == pytest.approx(0, abs=1e-12))  # I(0) = 0, I(255) = 1 kept


def test_equal_times_for_differing_images_are_refused(stack):
    times = TIMES.copy()
    times[2] = times[1]
    for call in (
        lambda: calibrate_response(stack, times),
        lambda: merge_hdr(stack, times, np.zeros(256)),
    ):
        with pytest.raises(ParameterError, match=r"images 1 and 2 the same exposure time"):
            call()
    # a repeated shot of one exposure is no contradiction
    repeated = np.concatenate([stack, stack[1:2]])
    result = calibrate_response(repeated, np.append(TIMES, TIMES[1]), "emor", bootstrap=0)
    assert _error_percent(result.inverse[:, 0]) < 0.8


def test_bad_arguments_are_named(stack):
    with pytest.raises(ParameterError, match="method"):
        calibrate_response(stack, TIMES, "gsolve")
    with pytest.raises(ParameterError, match="bootstrap"):
        calibrate_response(stack, TIMES, bootstrap=-1)
