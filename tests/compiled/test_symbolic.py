"""The tracer's array namespace (brdfkit.compiled.symbolic): JAX's promotion rules, what it
refuses, and that the compiled path traces without JAX."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from brdfkit._array import check_param, erf, is_abstract, namespace
from brdfkit.compiled.scalar_code import Sym
from brdfkit.compiled.symbolic import SymbolicArray, TraceError, trace


def _trace(fn, dtype=np.float32, shapes=((1, 3),)):
    em, outs = trace(fn, dtype, list(shapes))
    return em, outs


def test_python_scalars_take_the_arrays_dtype_and_float64_computes_in_float32() -> None:
    """Weak Python scalars do not widen float32; in a float32 trace NumPy float64 constants
    and requested float64 dtypes compute in float32 (JAX without 64-bit mode)."""

    def fn(w):
        xp = namespace(w)
        assert xp.finfo(xp.float64).eps == xp.finfo(w).eps == np.finfo(w.dtype).eps
        return w * 2.0, w * np.float64(0.5), xp.astype(w, xp.float64), w[..., 0] > 1

    _, (scaled, by_numpy, cast, compared) = _trace(fn)
    assert scaled.dtype == by_numpy.dtype == cast.dtype == np.float32
    assert compared.dtype == np.bool_ and compared.shape == (1,)
    _, outs = _trace(fn, np.float64)
    assert [o.dtype for o in outs[:3]] == [np.float64] * 3


def test_constants_fold_and_shared_expressions_are_emitted_once() -> None:
    def fn(w):
        xp = namespace(w)
        a = xp.sqrt(w[..., 0] * w[..., 1])
        b = xp.sqrt(w[..., 0] * w[..., 1])
        return a + b, xp.ones_like(w) * 3.0

    em, (_, threes) = _trace(fn)
    assert len(em.lines) == 3  # product, root, sum
    assert all(not isinstance(e, Sym) and e == 3.0 for e in threes.elements.flat)


def test_indexing_stacking_and_reductions_resolve_at_trace_time() -> None:
    def fn(w):
        xp = namespace(w)
        flipped = xp.stack([w[..., 2], w[..., 1], w[..., 0]], axis=-1)
        return xp.sum(flipped[..., ::2], axis=-1, keepdims=True), xp.mean(w, axis=-1)

    _, (ends, mean) = _trace(fn)
    assert ends.shape == (1, 1) and mean.shape == (1,)
    names = {s.name for s in ends.elements.flat} | {s.name for s in mean.elements.flat}
    assert len(names) == 2 and all(n.startswith("t") for n in names)


def test_traced_values_refuse_python_control_flow_and_gathers() -> None:
    def branch(w):
        return w if w[..., 0] > 0 else -w

    with pytest.raises(TraceError, match="Python control flow on array values"):
        _trace(branch)
    with pytest.raises(TraceError):
        _trace(lambda w: np.asarray(w))
    with pytest.raises(ValueError, match="indexing by traced values"):
        _trace(lambda w: namespace(w).take(w, namespace(w).astype(w[0], np.int32), axis=-1))
    with pytest.raises(TypeError, match="immutable"):
        _trace(lambda w: w.__setitem__(0, 1.0))


def test_constant_arrays_have_values_and_parameter_checks_are_skipped() -> None:
    def fn(w):
        xp = namespace(w)
        assert float(xp.asarray(0.25) * 2) == 0.5  # constants are known while tracing
        assert is_abstract(w)
        return check_param("alpha", w, 0.0, 1.0)  # no value to check: skipped

    _, (out,) = _trace(fn)
    assert isinstance(out, SymbolicArray)


def test_special_functions_use_the_kernels_own() -> None:
    em, (out,) = _trace(lambda w: erf(w[..., 0]))
    assert em.lines[-1][1].startswith("np.float32(math.erf(")
    assert out.dtype == np.float32


def test_tracing_imports_no_jax() -> None:
    """The compiled path's tracer works in an install without JAX."""
    code = (
        "import sys, json, numpy as np\n"
        "from brdfkit.brdf import MODELS\n"
        "from brdfkit.compiled import compiled_brdf, codegen, structure\n"
        "model = MODELS['ggx'](alpha=0.3, material='Au')\n"
        "_, values = structure.split(model)\n"
        "shapes = [v.shape for v in values]\n"
        "def traced(*args):\n"
        "    rebuilt = structure.rebuild(model, iter(args[:len(shapes)]))\n"
        "    return compiled_brdf._method(rebuilt, 'eval')(*args[len(shapes):])\n"
        "g = codegen.generate(traced, (3, 3), np.dtype(np.float32), shapes)\n"
        "print(json.dumps(['jax' in sys.modules, g.parameters, 'for i in range(n)' in g.source]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    jax_imported, parameters, looped = json.loads(out.stdout.strip().splitlines()[-1])
    assert not jax_imported and parameters > 0 and looped


def test_lines_cast_only_where_numba_would_type_them_otherwise() -> None:
    """A generated line drops its cast where numba types the expression as its dtype
    already (float arithmetic of one type, selects, comparisons of one type, boolean logic),
    and keeps it where the operands' types differ or the function's result type is numba's
    own choice."""
    from brdfkit.compiled.scalar_code import Emitter

    f32, f64, boolean = np.dtype(np.float32), np.dtype(np.float64), np.dtype(np.bool_)
    em = Emitter()
    a, b, wide, p = Sym("a", f32), Sym("b", f32), Sym("w", f64), Sym("p", boolean)

    def line(template, args, dtype):
        return em.lines[int(em.emit(template, args, dtype).name[1:])][1]

    assert line("{0} * {1}", [a, b], f32) == "a * b"
    assert line("{0} / {1}", [a, np.float32(2)], f32) == "a / k0"
    assert line("_select({0}, {2}, {1})", [p, a, b], f32) == "_select(p, b, a)"
    assert line("{0} > {1}", [a, b], boolean) == "a > b"
    assert line("_and({0}, {1})", [p, p], boolean) == "_and(p, p)"
    assert line("{0} * {1}", [a, wide], f32) == "np.float32(a * w)"
    assert line("{0} * {1}", [a, 0.5], f32) == "np.float32(a * k1)"  # a float64 global
    assert line("{0} > {1}", [a, wide], boolean) == "bool(a > w)"
    assert line("np.exp({0})", [a], f32) == "np.float32(np.exp(a))"
    assert line("{0} + {1}", [wide, wide], f32) == "np.float32(w + w)"
