"""The backend helpers: namespaces, dtype preservation, safe operations, special functions."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import special

from brdfkit import _array as A


def test_erf_basic_is_accurate_to_1e_7():
    x = np.linspace(-7, 7, 20001)
    err = np.abs(A.erf_basic(x) - special.erf(x))
    assert err.max() < 1e-7
    x32 = x.astype(np.float32)
    assert A.erf_basic(x32).dtype == np.float32
    assert np.abs(A.erf_basic(x32) - special.erf(x)).max() < 1e-6


def test_erf_dispatch_numpy_and_torch():
    torch = pytest.importorskip("torch")
    x = np.linspace(-3, 3, 101)
    np.testing.assert_allclose(A.erf(x), special.erf(x), atol=1e-15)
    t = torch.tensor(x, requires_grad=True)
    y = A.erf(t)
    assert isinstance(y, torch.Tensor)
    y.sum().backward()
    np.testing.assert_allclose(t.grad.numpy(), 2 / np.sqrt(np.pi) * np.exp(-x * x), rtol=1e-12)


@pytest.mark.parametrize(
    ("function", "reference", "shift"),
    [(A.erfinv, special.erfinv, 0.0), (A.log_gamma, special.gammaln, 2.0)],
)
def test_erfinv_and_log_gamma_match_scipy_on_numpy_and_torch(function, reference, shift):
    x = np.linspace(-0.999, 0.999, 11) + shift
    np.testing.assert_allclose(function(x), reference(x), rtol=1e-15)
    assert function(x.astype(np.float32)).dtype == np.float32
    torch = pytest.importorskip("torch")
    np.testing.assert_allclose(function(torch.tensor(x)).numpy(), reference(x), rtol=1e-12)


def test_safe_sqrt_and_div_have_finite_gradients_at_zero():
    torch = pytest.importorskip("torch")
    x = torch.tensor([-1e-12, 0.0, 4.0], dtype=torch.float64, requires_grad=True)
    y = A.safe_sqrt(x)
    y.sum().backward()
    assert torch.isfinite(x.grad).all()
    np.testing.assert_allclose(y.detach().numpy(), [0, 0, 2])
    b = torch.tensor([0.0, 2.0], dtype=torch.float64, requires_grad=True)
    q = A.safe_div(torch.tensor([1.0, 1.0], dtype=torch.float64), b)
    q.sum().backward()
    assert torch.isfinite(b.grad).all()
    np.testing.assert_allclose(q.detach().numpy(), [0, 0.5])


def test_normalize_cross_dot():
    a = np.array([[3.0, 0, 4], [0, 0, 0]])
    n = A.normalize(a)
    np.testing.assert_allclose(n, [[0.6, 0, 0.8], [0, 0, 0]])
    x, y = np.eye(3)[0], np.eye(3)[1]
    np.testing.assert_allclose(A.cross(x, y), [0, 0, 1])
    assert A.dot(a, a).tolist() == [25.0, 0.0]


def test_mixed_numpy_and_torch_computes_in_torch():
    torch = pytest.importorskip("torch")
    t = torch.ones(3, dtype=torch.float32)
    xp = A.namespace(np.ones(3), t)
    assert A.is_torch(xp)
    c = A.asarray(np.array([0.5, 0.25]), xp, like=t)
    assert isinstance(c, torch.Tensor) and c.dtype == torch.float32


def test_asarray_keeps_float32_and_constants_follow_like():
    x = np.ones(3, dtype=np.float32)
    assert A.asarray(x).dtype == np.float32
    assert A.asarray([1, 2]).dtype == np.float64
    assert A.constant(2.0, x).dtype == np.float32
    assert A.clamp(x, 0.0, 0.5).dtype == np.float32


def test_check_vectors_messages():
    with pytest.raises(ValueError, match=r"wi must have a last axis of length 3.*\(4, 2\)"):
        A.check_vectors("wi", np.zeros((4, 2)))
    with pytest.raises(ValueError, match="wo must be finite; got a value of nan"):
        A.check_vectors("wo", np.array([0, np.nan, 1.0]))


def test_asarrays_share_the_widest_float_dtype_and_backend():
    x32 = np.ones(2, dtype=np.float32)
    a, b = A.asarrays(x32, 0.5)
    assert a is x32 and b.dtype == np.float32 and float(b) == 0.5
    assert [v.dtype for v in A.asarrays(x32, np.zeros(2))] == [np.float64, np.float64]
    assert A.asarrays(1, [2, 3])[1].dtype == np.float64
    torch = pytest.importorskip("torch")
    t = torch.ones(2, dtype=torch.float32)
    c, d = A.asarrays(0.25, t)
    assert isinstance(c, torch.Tensor) and c.dtype == torch.float32 and d is t


def test_numpy_like_for_torch_data_gives_its_dtype_in_torch():
    torch = pytest.importorskip("torch")
    torch_xp = A.namespace(torch.ones(1))
    t = A.asarray([0.5, 0.25], torch_xp, like=np.ones(3, dtype=np.float32))
    assert isinstance(t, torch.Tensor) and t.dtype == torch.float32


def test_a_read_only_numpy_array_converts_to_torch_without_warning():
    torch = pytest.importorskip("torch")
    read_only = np.broadcast_to(np.arange(3.0), (2, 3))
    like = torch.zeros(1, dtype=torch.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        value = A.asarray(read_only, like=like)
    assert isinstance(value, torch.Tensor)
    np.testing.assert_array_equal(value.numpy(), read_only)
