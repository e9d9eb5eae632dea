"""The GLSL subset: every construct (tests/interop/data/constructs.brdf) against values written
here in NumPy, and every refusal naming the file, the line and the construct."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brdfkit.errors import FormatError
from brdfkit.interop.brdf_explorer import read_brdf_explorer
from brdfkit.interop.glsl import Value, run, translate

CONSTRUCTS = Path(__file__).parent / "data" / "constructs.brdf"


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


L, V = _directions(32, 1), _directions(32, 2)
N = np.array([0.0, 0.0, 1.0])


def _dot(a, b):
    return np.sum(a * b, axis=-1)


@pytest.fixture(scope="module")
def constructs():
    return read_brdf_explorer(CONSTRUCTS)


def _piecewise(x):
    return np.where(x < 0.3, 1.0, np.where(x < 0.6, 2 * x + 1, (x - 0.5) ** 2))


def _group1():
    h = (L + V) / np.linalg.norm(L + V, axis=-1, keepdims=True)
    hx, hy, hz = h.T
    return np.stack([2 * hz + hy / 2 - 0.5, 0.5 + hy / 2 - 0.5, hx + hy / 2 - 0.5], axis=-1)


def _group3():
    nl, nv = L[:, 2], V[:, 2]
    third = np.where(nl > nv, _dot(L, V), -_dot(L, V))
    return np.stack([_piecewise(nl), _piecewise(nv), third], axis=-1)


def _group4():
    z = L[:, 2]
    total = 1 + z + z**2 + z**3
    up = (L[:, 2] > 0.5) & (V[:, 2] > 0.5)
    either = (L[:, 2] > 0.5) | (V[:, 2] > 0.5)
    one = (L[:, 2] > 0.5) ^ (V[:, 2] > 0.5)
    second = np.where(up, 1.0, np.where(either, 2.0, 3.0))
    return np.stack([total, second, one + 10.0 + 100.0 + ~up], axis=-1)


def _group5():
    a, b = L[:, 2], V[:, 2]
    s1 = (np.sin(a) + np.cos(b) + np.tan(a / 2) + np.arcsin(a / 2) + np.arccos(b / 2)
          + np.arctan(a) + np.arctan2(a, b) + np.sinh(a) + np.cosh(b) + np.tanh(a))  # fmt: skip
    s2 = (np.exp(a) + np.log(b + 1) + 2**a + np.log2(b + 1) + np.sqrt(a) + 1 / np.sqrt(b + 1)
          + a + np.sign(a - b) + np.floor(3 * a) + np.ceil(3 * b) + (3 * a - np.floor(3 * a))
          + (5 * a - 0.7 * np.floor(5 * a / 0.7)) + np.trunc(3 * b) + np.round(3 * a)
          + np.radians(a) + np.degrees(b))  # fmt: skip
    user_reflect = 2 * _dot(-L, N)[:, None] * N + L  # the file's own reflect: 2(I·N)N − I
    eta, cos_i = 0.75, _dot(N, -L)
    k = 1 - eta**2 * (1 - cos_i**2)
    refracted = eta * -L - (eta * cos_i + np.sqrt(k))[:, None] * N
    faceforward = np.where((_dot(N, -L) < 0)[:, None], N, -N)
    s3 = (np.minimum(a, b) + np.maximum(a, b) + np.clip(2 * a, 0.25, 0.75) + (0.75 * a + 0.25 * b)
          + (a >= 0.5) + _smoothstep(0.2, 0.8, b) + 2 * np.linalg.norm(L - V, axis=-1)
          + _dot(L, V) + a**1.5 + np.linalg.norm(np.cross(L, V), axis=-1)
          + _dot(user_reflect, V) + _dot(refracted, V) + _dot(faceforward, V))  # fmt: skip
    return np.stack([s1, s2, s3], axis=-1)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0, 1)
    return t * t * (3 - 2 * t)


def _group6(flip: bool, gain: float = 1.5):
    c = np.maximum(2 * np.array([0.2, 0.4, 0.6]) - 0.5, 0.1) * gain
    c = -c if flip else c
    c = 0.5 * c + 0.5 * np.array([1.0, 0.0, 0.0])
    k = np.stack([L[:, 0] / 2, V[:, 1] / 2, np.full(len(L), 3.0)], axis=-1)
    shifted = L + np.array([0.25, 0.0, 0.0])
    return c + k + shifted[:, ::-1]


EXPECTED = {
    0: lambda: np.broadcast_to(np.array([0.2, 0.4, 0.6]) / np.pi, L.shape),
    1: _group1,
    2: lambda: np.broadcast_to([2073.0, 1.0, 1.0], L.shape),
    3: _group3,
    4: _group4,
    5: _group5,
    6: lambda: _group6(False),
}


@pytest.mark.parametrize("which", sorted(EXPECTED))
def test_every_construct_of_the_subset_computes_what_numpy_does(constructs, which):
    value = constructs.with_values(which=float(which)).shader_value(L, V)
    np.testing.assert_allclose(value, EXPECTED[which](), rtol=1e-12, atol=1e-12)


def test_uniform_parameters_of_every_kind(constructs):
    value = constructs.with_values(which=6.0, flip=True, gain=0.5).shader_value(L, V)
    np.testing.assert_allclose(value, _group6(True, 0.5), rtol=1e-12)


def test_float32_and_torch_keep_their_dtype_and_gradients(constructs):
    brdf = constructs.with_values(which=3.0)
    value32 = brdf.shader_value(L.astype(np.float32), V.astype(np.float32))
    assert value32.dtype == np.float32
    np.testing.assert_allclose(value32, _group3(), rtol=1e-5, atol=1e-6)
    torch = pytest.importorskip("torch")
    wi = torch.tensor(L, requires_grad=True)
    out = brdf.shader_value(wi, torch.tensor(V))
    out[:, 0].sum().backward()  # d/dz piecewise: 0, 2 or 2(z - 0.5)
    z = L[:, 2]
    expected = np.where(z < 0.3, 0.0, np.where(z < 0.6, 2.0, 2 * (z - 0.5)))
    np.testing.assert_allclose(wi.grad[:, 2].numpy(), expected, rtol=1e-12)


def test_define_constants_expand_in_plain_glsl():
    program = translate("#define TWO_PI (2.0 * PI)\n#define PI 3.0\nfloat f() { return TWO_PI; }")
    x = np.zeros(2)
    assert float(run(program, "f", [], {}, like=x).parts[0]) == 6.0


def test_a_uniform_declared_in_glsl_takes_the_value_given():
    program = translate("uniform float k;\nfloat f(float x) { return k * x; }")
    x = np.array([1.0, 2.0])
    k = Value("float", (np.asarray(3.0),))
    np.testing.assert_array_equal(run(program, "f", [Value("float", (x,))], {"k": k}, x).parts[0],
                                  [3.0, 6.0])  # fmt: skip
    with pytest.raises(FormatError, match=r"line 1\): GLSL: no value for uniform 'k'"):
        run(program, "f", [Value("float", (x,))], {}, x)


def test_names_that_begin_like_refused_types_and_prototypes_are_fine():
    program = translate(
        "float scaled(float x);\n"
        "float scaled(float x) { float material = 2.0, imageScale = 3.0, uintish = 4.0;\n"
        "  return material * imageScale * uintish * x; }"
    )
    x = np.array([0.5])
    assert float(run(program, "scaled", [Value("float", (x,))], {}, x).parts[0][0]) == 12.0


REFUSED = [
    ("float f(float x) {\n  while (x > 0.0) x -= 1.0;\n  return x; }", 2, "'while' loop"),
    ("float f(float x) {\n  mat3 m;\n  return x; }", 2, "unsupported type 'mat3'"),
    ("float f(float x) { float a[3];\n return x; }", 1, "array 'a[…]'"),
    ("void f(out float x) { x = 1.0; }", 1, "'out' parameter"),
    ("float f(float x) {\n\n  return x & 1; }", 3, "bitwise operator '&'"),
    ('#include "x.h"\nfloat f() { return 1.0; }', 1, "preprocessor directive '#include'"),
    ("#define SQR(x) x*x\nfloat f() { return 1.0; }", 1, "function-like macro 'SQR(…)'"),
    ("float f(float x) {\n  return texture2D(x); }", 2, "unknown function 'texture2D'"),
    ("float f(float x) { for (;;) { break; } return x; }", 1, "'break'"),
    ("struct S { float a; };", 1, "'struct'"),
    ("float f(float x) { return x; }\nfloat f(vec3 x) { return 1.0; }", 2, "defined twice"),
    ("float f(float x) {\n  return x $ 2.0; }", 2, "unexpected character '$'"),
    ("float f(float x) { /* never closed\n return x; }", 1, "unterminated comment"),
    ("float f(float x) {\n  return (x + 1.0; }", 2, "expected ')' to close '('"),
]


@pytest.mark.parametrize(("source", "line", "construct"), REFUSED)
def test_what_the_subset_cannot_express_is_refused_by_file_line_and_construct(
    source, line, construct
):
    with pytest.raises(FormatError) as caught:
        translate(source, "shader.glsl")
    message = str(caught.value)
    assert message.startswith(f"shader.glsl (line {line}): GLSL: ")
    assert construct in message


EVALUATION_REFUSED = [
    ("float f(float x) {\n  vec2 v = vec2(x);\n  return v + vec3(x); }", 3, "vec2 and vec3"),
    ("float f(float x) {\n  int i = x;\n  return 1.0; }", 2, "is float, expected int"),
    ("float f(float x) {\n  if (x) return 1.0;\n  return 0.0; }", 2, "of type float"),
    ("float f(float x) {\n  for (float t = 0.0; t < x; t += 1.0) {}\n  return x; }", 2,
     "condition varies"),
    ("float f(float x) { return f(x); }", 1, "recursion"),
    ("float f(float x) {\n  return y; }", 2, "undeclared name 'y'"),
    ("float g = 1.0;\nfloat f(float x) {\n  g = x;\n  return g; }", 3, "global or uniform 'g'"),
    ("float f(float x) {\n  vec3 v = vec3(x);\n  return v[int(x)]; }", 3, "not a constant int"),
]  # fmt: skip


@pytest.mark.parametrize(("source", "line", "construct"), EVALUATION_REFUSED)
def test_what_cannot_be_evaluated_is_refused_by_file_line_and_construct(source, line, construct):
    x = np.linspace(0.1, 0.9, 3)
    with pytest.raises(FormatError) as caught:
        run(translate(source, "shader.glsl"), "f", [Value("float", (x,))], {}, x)
    message = str(caught.value)
    assert message.startswith(f"shader.glsl (line {line}): GLSL: ")
    assert construct in message
