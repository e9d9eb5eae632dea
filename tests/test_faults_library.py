"""The library's edges: mixed backends, half precision, sample counts, huge integers and wrong
shapes give a result or a ParameterError naming the argument, never a raw error or NaN."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import MODELS, parse
from brdfkit.errors import ParameterError, ResourceError

WI = np.array([0.3, 0.1, 0.9]) / np.linalg.norm([0.3, 0.1, 0.9])
WO = np.array([-0.2, 0.3, 0.9]) / np.linalg.norm([-0.2, 0.3, 0.9])


def test_torch_parameters_with_numpy_directions_compute_in_torch():
    """ "'Float64DType' object has no attribute 'is_floating_point'" in every model."""
    torch = pytest.importorskip("torch")
    mixed = MODELS["ggx"](alpha=torch.tensor(0.3, dtype=torch.float64)).eval(WI, WO)
    reference = MODELS["ggx"](alpha=0.3).eval(WI, WO)
    assert isinstance(mixed, torch.Tensor)
    np.testing.assert_allclose(mixed.numpy(), reference, rtol=1e-12)


@pytest.mark.parametrize("spec", ["thin_film", "blinn_phong(n=10000)"])
def test_half_precision_directions_compute_in_float32(spec):
    """Float16 unit inputs gave all-NaN, silently."""
    half = parse(spec).eval(WI.astype(np.float16), WO.astype(np.float16))
    reference = parse(spec).eval(WI.astype(np.float16).astype(np.float32),
                                 WO.astype(np.float16).astype(np.float32))  # fmt: skip
    assert half.dtype == np.float32 and np.all(np.isfinite(half))
    np.testing.assert_array_equal(half, reference)


@pytest.mark.parametrize(
    ("samples", "error"),
    [(0, ParameterError), (-1, ParameterError), (2.5, ParameterError), (10**12, ResourceError)],
)
def test_albedo_samples_are_checked(samples, error):
    """samples=0 returned NaN; negative or huge ones raised raw errors."""
    with pytest.raises(error, match="samples"):
        parse("ggx").albedo(WO, samples=samples)


def test_an_integer_beyond_the_float_range_is_a_parameter_error():
    """10**400 gave "ufunc 'isfinite' not supported"."""
    with pytest.raises(ParameterError, match="alpha must be a number"):
        MODELS["ggx"](alpha=10**400)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_directions_of_two_components_are_a_parameter_error(name):
    """Directions with a last axis of 2 gave IndexErrors in 23 models."""
    model = parse(name)
    with pytest.raises(ParameterError, match=r"wi must be directions of shape \(\.\.\., 3\)"):
        model.eval(WI[:2], WO)
    with pytest.raises(ParameterError, match="wo must be directions"):
        model.pdf(WI, WO[:2])
    with pytest.raises(ParameterError, match="wo must be directions"):
        model.sample(WO[:2], np.full(3, 0.5))


def test_a_nan_direction_is_a_parameter_error_not_an_index_error():
    """A NaN direction in rough_plastic gave an IndexError."""
    with pytest.raises(ParameterError, match="finite"):
        parse("rough_plastic").eval(np.array([np.nan, 0.0, 1.0]), WO)
