"""Array-namespace helpers: the one place in brdfkit that knows about backends.

Every other module writes its arithmetic against the Python array API standard through
:func:`namespace` (``xp = namespace(wi, wo)``) and the small vocabulary below, so that the
same code runs on NumPy (the reference), PyTorch (autograd, GPU) and JAX (``jit``, autodiff).
Dtype and device of the inputs are kept: float32 stays float32, a CUDA tensor stays on the GPU.

References
----------
.. [1] Python array API standard, https://data-apis.org/array-api/
.. [2] array-api-compat, https://data-apis.org/array-api-compat/
.. [3] NumPy 2.1 release notes: the main namespace implements the array API standard 2023.12,
       https://numpy.org/doc/stable/release/2.1.0-notes.html
"""

from __future__ import annotations

import math
import operator
from typing import Any

import array_api_compat
import numpy as np

from brdfkit.errors import ParameterError

Array = Any
"""Any array of a supported backend (``numpy.ndarray``, ``torch.Tensor``, ``jax.Array``)."""


_NUMPY = (np.ndarray, np.generic)
_NUMPY_OR_NOT_ARRAYS = (*_NUMPY, type(None), int, float, bool, complex, list, tuple)


def _numpy_namespace() -> Any:
    """NumPy's array-API namespace: the ``numpy`` module itself from NumPy 2.1 on (it
    implements the standard's 2023.12 revision, ``asarray``/``astype``/``reshape`` with
    ``device`` and ``copy`` included), else array-api-compat's wrapper of it. The wrapper
    copies the whole ``numpy`` module when imported (~0.3 s, its ``f2py`` and ``typing``
    with it), which every process that renders would pay."""
    if getattr(np, "__array_api_version__", "") >= "2023.12":
        return np
    import array_api_compat.numpy

    return array_api_compat.numpy


NUMPY_NAMESPACE = _numpy_namespace()
"""The namespace :func:`namespace` gives NumPy arrays, Python scalars and lists."""


def namespace(*arrays: Any) -> Any:
    """The array-API namespace of ``arrays``; Python scalars and ``None`` are ignored.

    With no array among ``arrays`` the NumPy namespace is returned, so plain lists and floats
    are computed with NumPy.
    """
    # NumPy arrays mixed with tensors of another backend (parameters given as NumPy, directions
    # as torch, say) compute in the other backend: NumPy converts losslessly into any of them.
    others = [a for a in arrays if not isinstance(a, _NUMPY_OR_NOT_ARRAYS)]
    if not others:
        # NumPy only (or nothing): what array_namespace answers, without its checks, which
        # cost more than a small array operation (models ask here dozens of times per call).
        return NUMPY_NAMESPACE
    return array_api_compat.array_namespace(*others)


def is_numpy(xp: Any) -> bool:
    """Whether ``xp`` is the NumPy namespace."""
    return xp is NUMPY_NAMESPACE or array_api_compat.is_numpy_namespace(xp)


def is_torch(xp: Any) -> bool:
    """Whether ``xp`` is the PyTorch namespace."""
    return array_api_compat.is_torch_namespace(xp)


def is_jax(xp: Any) -> bool:
    """Whether ``xp`` is the JAX namespace."""
    return array_api_compat.is_jax_namespace(xp)


def float_dtype(xp: Any, *arrays: Any) -> Any:
    """The floating dtype computations on ``arrays`` should use.

    Floating inputs keep their dtype (the widest among them wins); integer input, Python
    scalars and lists compute in float64 (float32 on torch, whose default is float32).
    """
    dtypes = [
        a.dtype
        for a in arrays
        if hasattr(a, "dtype") and namespace(a) is xp and xp.isdtype(a.dtype, "real floating")
    ]
    if dtypes:
        widest = dtypes[0]
        for d in dtypes[1:]:
            widest = xp.result_type(widest, d)
        return widest
    if is_torch(xp):
        import torch

        return torch.get_default_dtype()
    return xp.float64


def asarray(x: Any, xp: Any = None, *, like: Any = None, dtype: Any = None) -> Array:
    """``x`` as a floating array of namespace ``xp`` (or of ``like``), keeping float dtypes.

    ``like`` gives the dtype and device to use when ``x`` is a Python scalar or list: constants
    created through it never promote float32 data to float64 or move GPU data to the host.
    """
    if (
        dtype is not None
        and (xp is None or xp is NUMPY_NAMESPACE)
        and (like is None or isinstance(like, _NUMPY))
    ):
        # The common NumPy cases, answered before the general rules below.
        if type(x) is np.ndarray and x.dtype == dtype:
            return x
        if type(x) is float or type(x) is int:
            return np.asarray(x, dtype=dtype)
    if xp is None:
        xp = namespace(x, like)
    native = hasattr(x, "dtype") and namespace(x) is xp
    like_dtype = device = None
    if like is not None and hasattr(like, "dtype"):
        if namespace(like) is xp:
            like_dtype, device = like.dtype, _device(like)
        elif isinstance(like, np.ndarray | np.generic):
            # A NumPy ``like`` for data of another backend: its dtype, by name, in that backend.
            like_dtype = getattr(xp, np.dtype(like.dtype).name, None)
    if dtype is None:
        if like_dtype is not None and xp.isdtype(like_dtype, "real floating"):
            dtype = like_dtype
            if native and xp.isdtype(x.dtype, "real floating"):
                dtype = xp.result_type(x.dtype, like_dtype)
        elif hasattr(x, "dtype") and not native and np.issubdtype(np.dtype(x.dtype), np.floating):
            dtype = None  # a foreign float array (NumPy into torch): conversion keeps its width
        else:
            dtype = float_dtype(xp, x)
    if native and x.dtype == dtype and (device is None or _device(x) == device):
        return x  # already right: no copy, autograd graph kept
    if device is None and native:
        device = _device(x)
    if isinstance(x, np.ndarray) and not native and not x.flags.writeable:
        x = x.copy()  # a read-only view (a broadcast, a cached table): torch wants its own
    return xp.asarray(x, dtype=dtype, device=device)


def asarrays(*values: Any) -> list[Array]:
    """``values`` as floating arrays of one namespace, dtype (the widest float input) and device.

    Python scalars and lists take the dtype and device of the array inputs; with none, NumPy's
    float64.
    """
    xp = namespace(*values)
    dtype = float_dtype(xp, *values)
    like = next((v for v in values if hasattr(v, "dtype") and namespace(v) is xp), None)
    return [asarray(v, xp, like=like, dtype=dtype) for v in values]


def constant(value: float, like: Array) -> Array:
    """A 0-d array holding ``value`` with the dtype and device of ``like``."""
    if isinstance(like, _NUMPY):
        return np.asarray(value, dtype=like.dtype)
    xp = namespace(like)
    return xp.asarray(value, dtype=like.dtype, device=array_api_compat.device(like))


def _device(x: Array) -> Any:
    """The device of ``x`` (``"cpu"`` for NumPy, answered without array-api-compat's checks)."""
    return "cpu" if isinstance(x, _NUMPY) else array_api_compat.device(x)


def dot(a: Array, b: Array, *, keepdims: bool = False) -> Array:
    """Dot product over the last axis, broadcasting the batch axes.

    For 3-vectors it is written out component by component: a reduction over a length-3 axis
    is several times slower on NumPy and fuses badly under compilers.
    """
    if a.shape[-1] == 3 and b.shape[-1] == 3:
        d = a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]
        return d[..., None] if keepdims else d
    xp = namespace(a, b)
    return xp.sum(a * b, axis=-1, keepdims=keepdims)


def norm(a: Array, *, keepdims: bool = False) -> Array:
    """Euclidean norm over the last axis."""
    xp = namespace(a)
    return xp.sqrt(dot(a, a, keepdims=keepdims))


HOLDS_NORMAL = 0.5
"""A stored normal map holds a normal where its vector is longer than this: unit normals
(quantised, or not quite normalised) do; the backgrounds maps are written with, zeros or an
encoded map's mid-grey (length under 1e-2 at 8 bits), do not."""


def holds_normal(normals: Array) -> Array:
    """``(...,)`` bool: where a normal map ``(..., 3)`` holds a normal (its vector longer than
    :data:`HOLDS_NORMAL`), the object when no mask is given."""
    return norm(normals) > HOLDS_NORMAL


def normalize(a: Array) -> Array:
    """``a`` divided by its norm over the last axis (zero vectors stay zero, without NaN).

    The squared norm is floored at float32's smallest normal number before its square root
    (so vectors shorter than 1.1e-19 come out shorter than unit, never NaN): a division by a
    square root, which the compiled path (:mod:`brdfkit.compiled`) turns into a
    multiplication by a reciprocal square root."""
    xp = namespace(a)
    squared = dot(a, a, keepdims=True)
    tiny = constant(np.finfo(np.float32).tiny, squared)
    return a / xp.sqrt(xp.maximum(squared, tiny))


def channels_first(x: Array, ndim: int) -> Array:
    """``x``, broadcastable to ``batch + (C,)`` with ``ndim`` axes in all, as ``(C,) + batch``
    (a view: missing leading axes added, the last axis moved first). :func:`channels_last`
    undoes it."""
    xp = namespace(x)
    x = xp.reshape(x, (1,) * (ndim - x.ndim) + tuple(x.shape))
    return xp.permute_dims(x, (ndim - 1, *range(ndim - 1)))


def channels_last(x: Array) -> Array:
    """``(C,) + batch`` as ``batch + (C,)`` (a view), the inverse of :func:`channels_first`."""
    return namespace(x).permute_dims(x, (*range(1, x.ndim), 0))


def cross(a: Array, b: Array) -> Array:
    """Cross product of 3-vectors over the last axis, broadcasting the batch axes."""
    xp = namespace(a, b)
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return xp.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)


def clamp(x: Array, lo: float | None = None, hi: float | None = None) -> Array:
    """``x`` limited to ``[lo, hi]`` (either bound may be omitted); differentiable inside."""
    xp = namespace(x)
    if lo is not None:
        x = xp.maximum(x, constant(lo, x))
    if hi is not None:
        x = xp.minimum(x, constant(hi, x))
    return x


def safe_sqrt(x: Array) -> Array:
    """``sqrt(max(x, 0))``: no NaN from rounding below zero (NaN gives 0), and a finite
    gradient at 0.

    The gradient needs a double ``where`` (autograd backends differentiate both branches); NumPy
    has no gradient and computes the same values as ``sqrt(fmax(x, 0))``, in two fast passes
    instead of six (``numpy.where`` is several times slower than arithmetic).
    """
    xp = namespace(x)
    if is_numpy(xp):
        root = np.fmax(x, 0)
        if isinstance(root, np.ndarray) and root.dtype.kind == "f":
            return np.sqrt(root, out=root)  # in place: ``root`` is our own temporary
        return np.sqrt(root)
    positive = x > 0
    return xp.where(positive, xp.sqrt(xp.where(positive, x, constant(1, x))), constant(0, x))


def safe_div(a: Array, b: Array) -> Array:
    """``a / b`` where ``b != 0``, else 0 (and no NaN in either branch's gradient).

    On NumPy (no gradient) the quotient is computed directly and its zero-divisor entries are
    overwritten only where there are any: the same values in two passes instead of five.
    """
    xp = namespace(a, b)
    if is_numpy(xp):
        if np.all(b):  # no zero divisor (one pass, no temporary): the plain quotient
            return np.divide(a, b)
        with np.errstate(divide="ignore", invalid="ignore"):
            quotient = np.asarray(np.divide(a, b))
        np.copyto(quotient, 0, where=b == 0)
        return quotient
    nonzero = b != 0
    quotient = a / xp.where(nonzero, b, constant(1, b))
    return xp.where(nonzero, quotient, constant(0, quotient))


def where(condition: Array, x: Array | float, y: Array | float) -> Array:
    """``xp.where`` that accepts Python scalars on either side (made with the other's dtype)."""
    xp = namespace(condition, x, y)
    ref = x if hasattr(x, "dtype") else y
    if not hasattr(x, "dtype"):
        x = constant(x, ref)
    if not hasattr(y, "dtype"):
        y = constant(y, ref)
    return xp.where(condition, x, y)


def _backend_special(x: Array, scipy_name: str, torch_name: str) -> Array | None:
    """``x`` through the backend's own special function, or ``None`` if it has none.

    NumPy uses ``scipy.special.<scipy_name>`` (dtype kept), PyTorch ``torch.<torch_name>``,
    JAX ``jax.scipy.special.<scipy_name>``; all three differentiate through it where they can.
    Another namespace that has ``<scipy_name>`` itself uses it.
    """
    xp = namespace(x)
    if is_numpy(xp):
        from scipy import special

        return xp.asarray(getattr(special, scipy_name)(x), dtype=x.dtype)
    if is_torch(xp):
        import torch

        return operator.attrgetter(torch_name)(torch)(x)
    if is_jax(xp):
        import jax.scipy.special

        return getattr(jax.scipy.special, scipy_name)(x)
    own = getattr(xp, scipy_name, None)  # a namespace with its own (brdfkit.compiled's tracer)
    return None if own is None else own(x)


def erf(x: Array) -> Array:
    """The error function, using the backend's own where it has one.

    NumPy uses :func:`scipy.special.erf`, PyTorch :func:`torch.special.erf`, JAX
    :func:`jax.scipy.special.erf`. Any other backend gets :func:`erf_basic`.
    """
    value = _backend_special(x, "erf", "special.erf")
    return erf_basic(x) if value is None else value


def erfinv(x: Array) -> Array:
    """The inverse error function erf⁻¹(x) for x in (−1, 1), the backend's own.

    NumPy uses :func:`scipy.special.erfinv`, PyTorch :func:`torch.special.erfinv`, JAX
    :func:`jax.scipy.special.erfinv`.

    Raises
    ------
    ValueError
        For a backend with no inverse error function.
    """
    value = _backend_special(x, "erfinv", "special.erfinv")
    if value is None:
        raise ValueError(f"x must be a NumPy, PyTorch or JAX array for erfinv; got {type(x)!r}")
    return value


def log_gamma(x: Array) -> Array:
    """ln Γ(x) for x > 0, the backend's own (:func:`scipy.special.gammaln`,
    :func:`torch.lgamma`, :func:`jax.scipy.special.gammaln`).

    Raises
    ------
    ValueError
        For a backend with no log-gamma function.
    """
    value = _backend_special(x, "gammaln", "lgamma")
    if value is None:
        raise ValueError(f"x must be a NumPy, PyTorch or JAX array for log_gamma; got {type(x)!r}")
    return value


_ERF_TERMS = 80


def erf_basic(x: Array) -> Array:
    """The error function from basic array operations only, accurate to 1e-7 (float64: ~1e-15).

    Uses the everywhere-convergent series with positive terms (A&S 7.1.6)
    ``erf(x) = 2/√π · exp(−x²) · Σₙ 2ⁿ x^(2n+1) / (1·3·…·(2n+1))``, which has no cancellation;
    beyond ``|x| = 6`` (float64) or ``|x| = 4`` (narrower types) erf is ±1 to that precision,
    and stopping there keeps rounding in the growing partial sums small.

    References
    ----------
    .. [1] M. Abramowitz and I. A. Stegun, *Handbook of Mathematical Functions*, eq. 7.1.6.
    """
    xp = namespace(x)
    saturation = 6.0 if x.dtype == xp.float64 else 4.0
    a = xp.minimum(xp.abs(x), constant(saturation, x))
    two_a2 = 2 * a * a
    term = a
    total = a
    for n in range(1, _ERF_TERMS):
        term = term * two_a2 / (2 * n + 1)
        total = total + term
    value = 2 / math.sqrt(math.pi) * xp.exp(-a * a) * total
    value = xp.minimum(value, xp.ones_like(value))
    return xp.where(x < 0, -value, value)


def check_vectors(name: str, v: Array, *, finite: bool = True) -> Array:
    """Validate a direction/point array: last axis of length 3 and (by default) finite values.

    Raises
    ------
    ValueError
        Naming ``name``, the shape or the offending value, and what was expected.
    """
    xp = namespace(v)
    v = asarray(v, xp)
    if v.ndim == 0 or v.shape[-1] != 3:
        raise ValueError(
            f"{name} must have a last axis of length 3 (x, y, z); got shape {tuple(v.shape)}"
        )
    if finite:
        check_finite(name, v)
    return v


def is_abstract(x: Any) -> bool:
    """Whether ``x`` is an abstract value with no data to check: a tracer under ``jax.jit``, or
    an array of :mod:`brdfkit.compiled`'s tracer (its class says ``abstract = True``)."""
    if getattr(type(x), "abstract", False) is True:
        return True
    if not is_jax(namespace(x)):
        return False
    import jax

    return isinstance(x, jax.core.Tracer)


def check_finite(name: str, v: Array) -> Array:
    """Raise ``ValueError`` naming ``name`` if ``v`` holds NaN or infinity."""
    if is_abstract(v):  # under jax.jit values are abstract: skip data-dependent checks there
        return v
    xp = namespace(v)
    if not bool(xp.all(xp.isfinite(v))):
        bad = to_numpy(v)[~np.isfinite(to_numpy(v))].ravel()[0]
        raise ParameterError(f"{name} must be finite; got a value of {bad}")
    return v


def check_param(
    name: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    hint: str = "",
    slack: float = 0.0,
) -> Any:
    """Validate a parameter or argument: finite and inside ``[lo, hi]`` (either end optional).

    ``lo_open``/``hi_open`` make the ends open; ``slack`` accepts values up to that far beyond
    either end (rounding in computed cosines, say) while the message states the nominal range.
    The value is returned unchanged (a torch tensor keeps its autograd graph). Comparisons run
    in the value's own backend (no copy to the host unless there is an error to report), and are
    skipped for abstract JAX values under ``jax.jit``.

    Raises
    ------
    brdfkit.errors.ParameterError
        A ``ValueError`` naming the argument, the offending value and the allowed range, e.g.
        ``"alpha must be in (0.0, inf]; got -1"`` (``"must be finite and in …"`` for NaN or
        infinity). :mod:`brdfkit.fit.analytic` reads the model bounds back from this message for
        finite probes, so its ``must be in <interval>`` form is a contract.
    """
    low = -math.inf if lo is None else lo - slack
    high = math.inf if hi is None else hi + slack
    # Python floats (alone or in a list), the common case: checked without array calls
    floats = [value] if type(value) is float else value if type(value) in (list, tuple) else ()
    if floats and all(
        type(v) is float
        and math.isfinite(v)
        and (v > low if lo_open else v >= low)
        and (v < high if hi_open else v <= high)
        for v in floats
    ):
        return value
    if is_abstract(value):
        return value
    xp = namespace(value)
    values = value if hasattr(value, "dtype") else xp.asarray(value)
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    allowed = f"{left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"
    if is_numpy(xp) and values.dtype.kind not in "biuf":  # 10**400 is an object array
        raise ParameterError(f"{name} must be a number in {allowed}; got {str(value)[:40]}")
    finite = xp.isfinite(values)
    below = values <= low if lo_open else values < low
    above = values >= high if hi_open else values > high
    bad = ~finite | below | above
    if bool(xp.any(bad)):
        first = to_numpy(values)[to_numpy(bad)].ravel()[0]
        expected = f"in {allowed}" if bool(xp.all(finite)) else f"finite and in {allowed}"
        extra = f" ({hint})" if hint else ""
        raise ParameterError(f"{name} must be {expected}; got {first:g}{extra}")
    return value


def check_directions(**named: Any) -> None:
    """Refuse direction arguments that are not arrays of shape ``(..., 3)``.

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming the argument and the shape it has.
    """
    for name, value in named.items():
        shape = getattr(value, "shape", None)
        if shape is None or len(shape) == 0 or shape[-1] != 3:
            got = f"shape {tuple(shape)}" if shape is not None else type(value).__name__
            raise ParameterError(f"{name} must be directions of shape (..., 3); got {got}")


def in_backend_of(values: Any, *arrays: Array) -> tuple[Array, ...]:
    """``arrays`` in the backend :func:`namespace` gives them together with ``values`` (a
    model's parameters, say): NumPy arrays beside a tensor become tensors of its backend, as
    the module promises; all-NumPy input is returned as it is. Float16 arrays are widened to
    float32 (:func:`_no_half`).

    Examples
    --------
    >>> import numpy as np
    >>> import torch
    >>> (w,) = in_backend_of([torch.tensor(0.3)], np.array([0.0, 0.0, 1.0]))
    >>> type(w).__name__, w.dtype
    ('Tensor', torch.float64)
    """
    xp = namespace(*arrays, *values)
    if not is_numpy(xp):
        arrays = tuple(a if namespace(a) is xp else asarray(a, xp) for a in arrays)
    return tuple(_no_half(a) for a in arrays)


def _no_half(a: Array) -> Array:
    """``a`` widened to float32 if it is float16: the models' arithmetic (a Blinn-Phong
    exponent of 10⁴, a thin film's phases) overflows half precision, so half-precision input
    computes, and returns, in float32."""
    if str(getattr(a, "dtype", "")).endswith("float16"):
        xp = namespace(a)
        return xp.astype(a, xp.float32)
    return a


def to_numpy(x: Any) -> np.ndarray:
    """A NumPy copy/view of ``x`` (detached from autograd, moved to the host)."""
    if hasattr(x, "detach"):
        x = x.detach().cpu()
    return np.asarray(x)
