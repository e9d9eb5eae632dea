"""The toolkit of hand-written kernels (brdfkit.compiled.kernel_tools) against NumPy."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

import numba

from brdfkit import sampling
from brdfkit.compiled import kernel_tools


def test_float32_atan2_within_a_few_ulp():
    rng = np.random.default_rng(4)
    y, x = (
        (rng.standard_normal(100_000) * 10.0 ** rng.integers(-3, 3, 100_000)).astype(np.float32)
        for _ in range(2)
    )
    x[:8] = [0, -0.0, 1, -1, 0, 1e-30, -3, 2]
    y[:8] = [0, 1, 0, 0, -2, 1e-30, 0, -0.0]
    atan2, _, _ = kernel_tools.trigonometry(np.float32)

    @numba.njit
    def each(a, b, out):
        for i in range(a.size):
            out[i] = atan2(a[i], b[i])

    found = np.empty_like(y)
    each(y, x, found)
    exact = np.arctan2(y.astype(np.float64), x.astype(np.float64))
    ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    assert np.max(np.abs(found - exact) / np.maximum(ulp, 1e-45)) < 4


def _sin_cos(dtype, x):
    """The toolkit's sin and cos of ``x`` in ``dtype``, in a numba loop."""
    _, sin, cos = kernel_tools.trigonometry(dtype)

    @numba.njit
    def both(a, s, c):
        for i in range(a.size):
            s[i], c[i] = sin(a[i]), cos(a[i])

    a = x.astype(dtype)
    s, c = np.empty_like(a), np.empty_like(a)
    both(a, s, c)
    return s, c


def test_float32_sin_and_cos_within_a_few_ulp_and_float64_is_libm():
    x = np.random.default_rng(5).uniform(-20, 20, 100_000)
    s, c = _sin_cos(np.float64, x)
    np.testing.assert_array_equal(s, np.sin(x))
    np.testing.assert_array_equal(c, np.cos(x))
    x32 = x.astype(np.float32).astype(np.float64)
    for found, exact in zip(_sin_cos(np.float32, x), (np.sin(x32), np.cos(x32)), strict=True):
        ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
        error = np.abs(found - exact) / np.maximum(ulp, 1e-45)
        assert np.quantile(error, 0.999) < 3  # away from the functions' zeros
        assert np.max(np.abs(found - exact)) < 1e-6


def test_prefetch_is_llvm_prefetch_and_leaves_values_alone():
    prefetch = kernel_tools.prefetch()

    @numba.njit
    def total(values, rows):
        s = 0.0
        for j in range(rows.size):
            if j + 2 < rows.size:
                prefetch(values, rows[j + 2])
            s += values[rows[j]]
        return s

    values = np.arange(1000, dtype=np.float32).reshape(250, 4).reshape(-1)
    rows = np.array([3, 999, 0, 512, 7])
    assert total(values, rows) == float(values[rows].sum())
    assert "llvm.prefetch" in total.inspect_llvm(total.signatures[0])
    with pytest.raises(numba.TypingError):  # a strided view: no element pointer arithmetic
        total(values[::2], rows)


def test_select_chooses_without_a_branch():
    select = kernel_tools.select()

    @kernel_tools.vector_jit()
    def clamp(x, out):
        for i in range(x.size):
            out[i] = select(x[i] > 0.0, x[i], 0.0)

    x = np.linspace(-1, 1, 101)
    out = np.empty_like(x)
    clamp(x, out)
    np.testing.assert_array_equal(out, np.maximum(x, 0.0))
    assert " select " in clamp.inspect_llvm(clamp.signatures[0])


@pytest.mark.parametrize("buckets", [1, 3, 16, 200])
def test_guided_search_finds_the_bisection_intervals(buckets):
    """Rows of CDFs with flat runs (empty cells first, inside and last), variates on their
    nodes, 0 and just below 1: the guided scan finds sampling._find_interval's interval for
    every variate, from the guide of any bucket count."""
    rng = np.random.default_rng(7)
    rows, count = 5, 40
    weights = rng.random((rows, count)) ** 3
    weights[:, [0, 1, 17, 18, -1]] = 0.0
    weights[2, 3:30] = 0.0
    cdf = np.concatenate([np.zeros((rows, 1)), np.cumsum(weights, axis=1)], axis=1)
    cdf /= cdf[:, -1:]
    cdf[:, -1] = 1.0
    guide = kernel_tools.guide_table(cdf.ravel(), count, buckets, rows)
    assert guide.shape == (rows * buckets,) and guide.dtype == np.uint16
    below_one = 1 - np.finfo(np.float64).eps / 2
    u = np.concatenate([rng.random(3000), np.minimum(cdf.ravel(), below_one), [0.0, below_one]])
    row = rng.integers(0, rows, u.size)
    expected = sampling._find_interval(cdf.ravel(), row * (count + 1), u, count)
    guided_interval = kernel_tools.guided_search()

    @numba.njit
    def search(cdf, guide, row, u, out):
        for j in range(u.size):
            out[j] = guided_interval(cdf, row[j] * (count + 1), guide, row[j] * buckets,
                                     buckets, u[j], count)  # fmt: skip

    found = np.empty(u.size, np.int64)
    search(cdf.ravel(), guide, row, u, found)
    np.testing.assert_array_equal(found, expected)


def test_run_tasks_runs_every_item_once_on_the_pool():
    seen = []
    kernel_tools.run_tasks(seen.append, range(50), 3)
    assert sorted(seen) == list(range(50))


def test_empty_allocates_as_numpy_empty_in_the_calling_function():
    """Shape, dtype, C strides and alignment as ``np.empty``'s, with no function compiled for
    the allocation (whose environment a loading process would rebuild by importing
    ``numba.np.arrayobj``)."""
    empty = kernel_tools.empty()
    n = 5

    @numba.njit
    def make(m):
        a = empty(m, np.float32)
        b = empty((3, m), np.float64)
        c = empty((2, 3, n), np.uint64)
        d = empty(n, np.bool_)
        a[:] = 1.5
        return a, b, c, d

    found = make(7)
    expected = np.empty(7, np.float32), np.empty((3, 7)), np.empty((2, 3, 5), np.uint64)
    for array, like in zip(found, (*expected, np.empty(5, np.bool_)), strict=True):
        assert (array.shape, array.dtype, array.strides) == (like.shape, like.dtype, like.strides)
        assert array.flags.c_contiguous and array.flags.writeable
        assert array.ctypes.data % array.dtype.alignment == 0
    np.testing.assert_array_equal(found[0], np.full(7, 1.5, np.float32))
    llvm = make.inspect_llvm(make.signatures[0])
    assert "NumbaEnv5numba2np8arrayobj" not in llvm  # no function of numba's array module
    assert "NRT_MemInfo_alloc_aligned" in llvm


def test_empty_refuses_what_numpy_refuses():
    empty = kernel_tools.empty()

    @numba.njit
    def make(m):
        return empty((2, m), np.float64)

    with pytest.raises(ValueError, match="negative dimensions"):
        make(-1)
    with pytest.raises(ValueError, match="array is too big"):
        make(2**62)

    @numba.njit
    def from_text(m):
        return empty(m, "f8")

    with pytest.raises(numba.TypingError):  # a NumPy scalar type only
        from_text(3)


def test_flat_is_the_flat_view_of_a_c_array():
    flat = kernel_tools.flat()

    @numba.njit
    def view(a):
        v = flat(a)
        v[1] = -1.0
        return v

    a = np.arange(24.0).reshape(2, 3, 4)
    v = view(a)
    assert v.shape == (24,) and a[0, 0, 1] == -1.0  # a view: written through
    np.testing.assert_array_equal(v, a.reshape(-1))
    del a  # the view holds the memory it shares
    assert v[23] == 23.0 and v.base is not None
    llvm = view.inspect_llvm(view.signatures[0])
    assert "NumbaEnv5numba2np8arrayobj" not in llvm
    with pytest.raises(numba.TypingError):  # a strided view has no flat view
        view(np.arange(24.0).reshape(4, 6)[:, ::2])
