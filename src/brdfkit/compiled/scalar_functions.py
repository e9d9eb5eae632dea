r"""Scalar functions for the kernels that numba lacks or compiles to scalar library calls.

- :func:`sin_cos32`, :func:`atan2_32`: branch-free float32 ``sin``, ``cos`` and ``atan2``
  from Cephes' single-precision polynomials, which LLVM vectorises (libm's are scalar calls);
- :func:`erfinv`: the inverse error function (Beckmann sampling needs it);
- :func:`trigonometry`: ``(atan2, sin, cos)`` for a hand-written kernel of either dtype
  (float32 the above, float64 libm's: the NumPy path's values).

Each is compiled by :func:`~brdfkit.compiled.jit.exact_jit` (no fast-math flags, so that
reassociation cannot undo an argument reduction or a Newton step); LLVM inlines them into the
loops that call them. :func:`generated_code_functions` hands the traced kernels the ones
their source calls.

References
----------
.. [1] S. L. Moshier, Cephes Math Library, ``sinf.c``, ``atanf.c`` (single precision), 1989.
.. [2] W. J. Cody, W. Waite, *Software Manual for the Elementary Functions*, 1980.
.. [3] M. Giles, "Approximating the erfinv function", GPU Computing Gems Jade, 2011.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from brdfkit.compiled import cache
from brdfkit.compiled.jit import exact_jit, select

ERFINV_NEWTON_STEPS = 3
"""Newton steps of the float64 inverse error function (within 3 ulp of
:func:`scipy.special.erfinv` on [−1 + 2⁻⁵³, 1 − 2⁻⁵³], tested)."""


@functools.cache
def sin_cos32() -> tuple[Callable[[Any], Any], Callable[[Any], Any]]:
    r"""Branch-free float32 ``(sin, cos)`` that LLVM vectorises.

    Cephes' ``sinf``/``cosf``: the octant j = ⌊\|x\|·4/π⌋ rounded up to even, the reduced
    argument r = \|x\| − j·π/4 by Cody and Waite's three-part π/4 (exact products), then a
    degree-7 odd or degree-8 even polynomial in r on [−π/4, π/4], and the sign of the octant.
    Against float64: at most 2.5 ulp on \|x\| ≤ 20 and 3.4 ulp on \|x\| ≤ 8192 (libm's float32:
    1.4 ulp), except near zeros of the function, where the reduction's error is absolute
    (5×10⁻¹⁴ at x = 3π); beyond 8192 the reduction loses accuracy.
    """
    choose = select()
    f32 = np.float32
    four_over_pi = f32(1.27323954473516)
    dp1, dp2, dp3 = f32(0.78515625), f32(2.4187564849853515625e-4), f32(3.77489497744594108e-8)
    s0, s1, s2 = f32(-1.9515295891e-4), f32(8.3321608736e-3), f32(-1.6666654611e-1)
    c0, c1, c2 = f32(2.443315711809948e-5), f32(-1.388731625493765e-3), f32(4.166664568298827e-2)
    jit = exact_jit()

    @jit
    def reduce(x: Any) -> Any:
        """(|x| reduced to [−π/4, π/4], octant mod 4 ∈ {0, 2}, whether the octant is ≥ 4)."""
        ax = np.abs(x)
        j = np.floor(ax * four_over_pi)
        j = j + (j - f32(2) * np.floor(j * f32(0.5)))  # odd octants round up to even
        r = ((ax - j * dp1) - j * dp2) - j * dp3
        octant = j - f32(8) * np.floor(j * f32(0.125))
        upper = octant > f32(3)
        return r, choose(upper, octant - f32(4), octant), upper

    @jit
    def polynomials(r: Any) -> Any:
        z = r * r
        sine = ((s0 * z + s1) * z + s2) * z * r + r
        cosine = ((c0 * z + c1) * z + c2) * z * z - f32(0.5) * z + f32(1)
        return sine, cosine

    @jit
    def sin32(x: Any) -> Any:
        r, octant, upper = reduce(x)
        sine, cosine = polynomials(r)
        value = choose(octant == f32(2), cosine, sine)
        return choose((x < f32(0)) != upper, -value, value)

    @jit
    def cos32(x: Any) -> Any:
        r, octant, upper = reduce(x)
        sine, cosine = polynomials(r)
        value = choose(octant == f32(2), sine, cosine)
        return choose(upper != (octant > f32(1)), -value, value)

    for name, function in (("sin32", sin32), ("cos32", cos32)):
        cache.enable(function, cache.key("hand-written", name))
    return sin32, cos32


@functools.cache
def atan2_32() -> Callable[[Any, Any], Any]:
    r"""Branch-free float32 ``atan2(y, x)`` that LLVM vectorises.

    Cephes' ``atanf`` on z = min(\|x\|, \|y\|)/max(\|x\|, \|y\|) ∈ [0, 1]: above tan(π/8) the
    argument is reduced by atan z = π/4 + atan((z − 1)/(z + 1)), then a degree-9 odd
    polynomial; the octant and quadrant are restored by π/2 − a, π − a and the sign of y.
    Within a few float32 ulp of float64 ``arctan2`` (tested).
    """
    choose = select()
    f32 = np.float32
    p0, p1 = f32(8.05374449538e-2), f32(-1.38776856032e-1)
    p2, p3 = f32(1.99777106478e-1), f32(-3.33329491539e-1)
    tan_pi_8 = f32(0.4142135623730950)
    quarter_pi, half_pi, pi = f32(math.pi / 4), f32(math.pi / 2), f32(math.pi)
    zero, one = f32(0), f32(1)

    @exact_jit()
    def atan2(y: Any, x: Any) -> Any:
        ax, ay = np.abs(x), np.abs(y)
        big, small = max(ax, ay), min(ax, ay)
        z = small / choose(big > zero, big, one)
        reduced = z > tan_pi_8
        r = choose(reduced, (z - one) / (z + one), z)
        r2 = r * r
        a = (((p0 * r2 + p1) * r2 + p2) * r2 + p3) * r2 * r + r
        a = choose(reduced, a + quarter_pi, a)
        a = choose(ay > ax, half_pi - a, a)
        a = choose(x < zero, pi - a, a)
        return choose(y < zero, -a, a)

    return atan2


def trigonometry(dtype: Any) -> tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any]]:
    """numba ``(atan2, sin, cos)`` for a kernel in ``dtype``: float32 the branch-free ones that
    LLVM vectorises (:func:`atan2_32`, :func:`sin_cos32`; a few ulp), float64 libm's (the
    NumPy path's values)."""
    return _trigonometry(np.dtype(dtype).type)


@functools.cache
def _trigonometry(dtype: type) -> tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any]]:
    if dtype is np.float32:
        return atan2_32(), *sin_cos32()
    jit = exact_jit()

    @jit
    def atan2(y: Any, x: Any) -> Any:
        return np.arctan2(y, x)

    @jit
    def sin(x: Any) -> Any:
        return np.sin(x)

    @jit
    def cos(x: Any) -> Any:
        return np.cos(x)

    return atan2, sin, cos


@functools.cache
def erfinv() -> tuple[Callable[[Any], Any], Callable[[Any], Any]]:
    r"""The inverse error function ``(erfinv32, erfinv64)`` for the kernels.

    float32: Giles' single-precision approximation, w = −ln((1 − x)(1 + x)) and a degree-8
    polynomial in w − 2.5 (w < 5) or in √w − 3, times x (a few ulp). float64: that value (or
    the tail's asymptotic form beyond float32's range) as the start of
    :data:`ERFINV_NEWTON_STEPS` Newton steps on erf(t) = \|x\|, taken on ln erfc(t) = ln(1 − \|x\|)
    where \|x\| > ½ so that the residual keeps its digits near ±1. ±1 give ±∞ and \|x\| > 1 NaN,
    as :func:`scipy.special.erfinv`.
    """
    jit = exact_jit()
    choose = select()
    two_over_sqrt_pi = 2 / math.sqrt(math.pi)
    giles32, edges32 = _giles(np.float32), _edges(np.float32)
    giles64, edges64 = _giles(np.float64), _edges(np.float64)

    @jit
    def erfinv32(x: Any) -> Any:
        return edges32(x, giles32(x))

    @jit
    def erfinv64(x: Any) -> Any:
        a = abs(x)
        # Giles' fit covers float32's range (1 − a ≳ 1e-7); beyond, erfc(t) ≈ exp(−t²)/(t√π)
        # gives t² = −ln(1 − a) − ln(t√π), within 0.1 % there.
        w = -math.log(1 - a)
        asymptotic = math.sqrt(w - math.log(math.sqrt(w * math.pi)))
        t = choose(w > 16.0, asymptotic, giles64(a))
        for _ in range(ERFINV_NEWTON_STEPS):
            slope = two_over_sqrt_pi * math.exp(-t * t)  # erf'(t)
            tail = math.erfc(t)
            # Newton on erf(t) = a, or on ln erfc(t) = ln(1 − a) in the tail (nearly
            # quadratic in t there, and erfc has its digits where erf rounds to 1)
            central_step = (math.erf(t) - a) / slope
            tail_step = (math.log(tail) - math.log(1 - a)) * tail / -slope
            t = t - choose(a > 0.5, tail_step, central_step)
        return edges64(x, math.copysign(t, x))

    return erfinv32, erfinv64


_GILES_CENTRAL = (
    2.81022636e-08, 3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087,
    -0.00125372503, -0.00417768164, 0.246640727, 1.50140941,
)  # fmt: skip
_GILES_TAIL = (
    -0.000200214257, 0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773,
    -0.0076224613, 0.00943887047, 1.00167406, 2.83297682,
)  # fmt: skip


def _giles(dtype: type) -> Callable[[Any], Any]:
    """Giles' single-precision erfinv in ``dtype`` (its polynomials' coefficients rounded to
    ``dtype``), without the edges ±1."""
    choose = select()
    c = tuple(dtype(v) for v in _GILES_CENTRAL)
    t = tuple(dtype(v) for v in _GILES_TAIL)
    one, half_five, three = dtype(1), dtype(2.5), dtype(3)

    @exact_jit()
    def approximate(x: Any) -> Any:
        w = -np.log((one - x) * (one + x))
        v = w - half_five
        p = c[0]
        for k in range(1, 9):
            p = p * v + c[k]
        v = np.sqrt(w) - three
        q = t[0]
        for k in range(1, 9):
            q = q * v + t[k]
        return choose(w < dtype(5), p, q) * x

    return approximate


def _edges(dtype: type) -> Callable[[Any, Any], Any]:
    """``value`` inside (−1, 1), ±∞ at ±1 and NaN beyond, in ``dtype``."""
    choose = select()
    one, inf, nan = dtype(1), dtype(np.inf), dtype(np.nan)

    @exact_jit()
    def at_edges(x: Any, value: Any) -> Any:
        a = np.abs(x)
        return choose(a < one, value, choose(a == one, np.copysign(inf, x), nan))

    return at_edges


def generated_code_functions(source: str) -> dict[str, Any]:
    """The functions of this module that a traced kernel's ``source`` calls, by the names it
    calls them (``_sin32``, ``_cos32``, ``_erfinv32``, ``_erfinv64``)."""
    found: dict[str, Any] = {}
    if "_sin32(" in source or "_cos32(" in source:
        found["_sin32"], found["_cos32"] = sin_cos32()
    if "_erfinv32(" in source or "_erfinv64(" in source:
        found["_erfinv32"], found["_erfinv64"] = erfinv()
    return found


__all__ = [
    "ERFINV_NEWTON_STEPS",
    "atan2_32",
    "erfinv",
    "generated_code_functions",
    "sin_cos32",
    "trigonometry",
]
