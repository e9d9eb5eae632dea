"""The model spec language: round trips through to_spec, composition, and safe error handling."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

import brdfkit.brdf  # noqa: F401  (registers every model)
from brdfkit.brdf.base import MODELS, Scaled, Sum
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.brdf.spec import parse
from brdfkit.errors import ParameterError, SpecError
from brdfkit.params import MAX_SPEC_LENGTH
from brdfkit.sampling import square_to_uniform_hemisphere

EXAMPLES = [
    pytest.param(model, id=f"{name}[{i}]")
    for name, cls in sorted(MODELS.items())
    for i, model in enumerate(cls.examples())
]


def _pairs(n: int = 256, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    u = np.random.default_rng(seed).random((2, n, 2))
    return square_to_uniform_hemisphere(u[0]), square_to_uniform_hemisphere(u[1])


@pytest.mark.parametrize("model", EXAMPLES)
def test_to_spec_round_trips_every_example(model):
    spec = model.to_spec()
    parsed = parse(spec)
    assert type(parsed) is type(model)
    assert parsed.to_spec() == spec  # a fixed point: the spec says everything about the model
    wi, wo = _pairs()
    np.testing.assert_allclose(parsed.eval(wi, wo), model.eval(wi, wo), rtol=1e-9, atol=0)


@pytest.mark.parametrize("model", EXAMPLES[:1] + EXAMPLES[-1:])
def test_compositions_round_trip(model):
    for composed in (
        Lambertian(0.2) + model,
        0.5 * model,
        [0.9, 0.5, 0.25] * (Lambertian(0.1) + 0.5 * model),
        0.5 * (0.5 * model),
    ):
        parsed = parse(composed.to_spec())
        assert type(parsed) is type(composed)
        wi, wo = _pairs()
        np.testing.assert_allclose(parsed.eval(wi, wo), composed.eval(wi, wo), rtol=1e-9, atol=0)


def test_sum_and_scale_evaluate_to_the_closed_form():
    brdf = parse("lambertian(albedo=0.2) + 0.5 * lambertian(albedo=[0.8, 0.4, 0.2])")
    assert isinstance(brdf, Sum) and isinstance(brdf.lobes[1], Scaled)
    wi, wo = _pairs(8)
    expected = (0.2 + 0.5 * np.array([0.8, 0.4, 0.2])) / math.pi
    np.testing.assert_allclose(brdf.eval(wi, wo), np.broadcast_to(expected, (8, 3)), rtol=1e-14)


def test_bare_names_use_the_defaults_and_scaling_commutes():
    assert parse("lambertian").to_spec() == Lambertian().to_spec()
    assert parse("  lambertian()  ").to_spec() == Lambertian().to_spec()
    wi, wo = _pairs(8)
    left = parse("0.5 * lambertian(albedo=0.8)").eval(wi, wo)
    right = parse("lambertian(albedo=0.8) * 0.5").eval(wi, wo)
    np.testing.assert_array_equal(left, right)
    np.testing.assert_allclose(left, np.full((8, 1), 0.4 / math.pi), rtol=1e-14)


def test_parentheses_group_before_scaling():
    wi, wo = _pairs(8)
    grouped = parse("0.5 * (lambertian(albedo=0.2) + lambertian(albedo=0.6))").eval(wi, wo)
    ungrouped = parse("0.5 * lambertian(albedo=0.2) + lambertian(albedo=0.6)").eval(wi, wo)
    np.testing.assert_allclose(grouped, np.full((8, 1), 0.4 / math.pi), rtol=1e-14)
    np.testing.assert_allclose(ungrouped, np.full((8, 1), 0.7 / math.pi), rtol=1e-14)


def test_numbers_keep_their_sign_and_products_of_factors_multiply():
    wi, wo = _pairs(8)
    np.testing.assert_allclose(
        parse("0.5 * 0.5 * lambertian(albedo=+1)").eval(wi, wo), np.full((8, 1), 0.25 / math.pi)
    )
    with pytest.raises(ValueError, match=r"k must be in \[0.0, 1000000.0\]; got -0.5"):
        parse("-0.5 * lambertian")


def test_unknown_model_lists_the_known_models():
    with pytest.raises(ValueError, match="unknown model 'lambertain'") as info:
        parse("lambertain(albedo=0.5)")
    message = str(info.value)
    assert "did you mean 'lambertian'" in message
    for name in MODELS:
        assert name in message


def test_unknown_parameter_names_the_model_and_its_parameters():
    with pytest.raises(ValueError, match="model 'lambertian' has no parameter 'sigma'") as info:
        parse("lambertian(sigma=0.5)")
    assert "rho (or albedo), allow_unphysical" in str(info.value)


def test_aliases_name_the_same_parameter():
    wi, wo = _pairs(8)
    by_alias = parse("lambertian(albedo=0.3)")
    assert by_alias.to_spec() == parse("lambertian(rho=0.3)").to_spec()
    np.testing.assert_allclose(by_alias.eval(wi, wo), np.full((8, 1), 0.3 / math.pi), rtol=1e-15)
    with pytest.raises(ValueError, match="parameter 'rho' of model 'lambertian' is given twice"):
        parse("lambertian(albedo=0.3, rho=0.3)")


def test_bad_values_are_reported_with_the_model_name():
    with pytest.raises(ParameterError, match=r"lambertian: rho must be in \[0.0, 1.0\]; got 2"):
        parse("lambertian(albedo=2)")


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("ggx(alpha=1e308)", r"ggx: alpha must be in \[0.0001, 10.0\]; got 1e\+308"),
        ("blinn_phong(n=1e308)", r"blinn_phong: n must be in \[0.0, 1000000.0\]"),
        ("torrance_sparrow(m=1e-320)", r"torrance_sparrow: m must be in \[0.0001, 10.0\]"),
        ("ggx(material=2)", "ggx: material must be 'none' or a conductor"),
        ("ggx(alpha='rough')", "ggx: alpha must be a real number"),
        ("ggx(alpha=None)", "ggx: alpha must be a real number"),
        ("ggx(alpha=True)", "ggx: alpha must be a real number"),
        ("ggx(masking=1)", "ggx: masking must be one of"),
        ("lambertian(allow_unphysical=1)", "lambertian: allow_unphysical must be True or False"),
        ("lambertian(albedo=1e999)", "lambertian: rho must be finite"),
        ("lambertian(albedo=" + "9" * 400 + ")", "lambertian: rho must be finite"),
        ("1e6 * 1e6 * lambertian", r"k must be in \[0.0, 1000000.0\]; got 1e\+12"),
        ("lambertian * 1e300 * 1e300", "k must be finite"),
    ],
)
def test_values_outside_a_domain_raise_a_parameter_error(spec, match):
    with pytest.raises(ParameterError, match=match):
        parse(spec)


def test_long_sums_and_products_parse_without_recursion():
    brdf = parse(" + ".join(["lambertian"] * 1000))
    assert isinstance(brdf, Sum) and len(brdf.lobes) == 1000
    wi, wo = _pairs(4)
    np.testing.assert_allclose(brdf.eval(wi, wo), np.full((4, 1), 500 / math.pi), rtol=1e-12)
    scaled = parse("lambertian(albedo=0.5)" + " * 1.0" * 1000 + " * 0.5")
    assert isinstance(scaled, Scaled) and isinstance(scaled.inner, Lambertian)
    np.testing.assert_allclose(scaled.eval(wi, wo), np.full((4, 1), 0.25 / math.pi), rtol=1e-15)


def test_products_of_factors_of_different_lengths_are_rejected():
    with pytest.raises(SpecError, match=r"must have one length .* got lengths \[2, 3\]"):
        parse("[1, 2] * [1, 2, 3] * lambertian")


@pytest.mark.parametrize(
    "spec",
    [
        " + ".join(["lambertian"] * 5000),
        "lambertian" + " * 1" * 5000,
        "-" * 50_000 + "1",
        "(" * 300 + "lambertian" + ")" * 300,
        "lambertian(albedo=" + "[" * 300 + "0.5" + "]" * 300 + ")",
        "0.5 * (" * 300 + "lambertian" + ")" * 300,
        "lambertian" + ".a" * 5000,
        "lambertian" + "()" * 5000,
        "not " * 20_000 + "lambertian",
    ],
    ids=["sum", "product", "signs", "parentheses", "brackets", "scales", "attributes", "calls",
         "nots"],
)  # fmt: skip
def test_deep_nesting_and_long_chains_raise_a_spec_error(spec):
    with pytest.raises(SpecError, match=r"too deeply|not a valid model expression|not allowed"):
        parse(spec)


def test_a_spec_has_a_maximum_length():
    spec = "lambertian(albedo=[" + ", ".join(["0.5"] * (MAX_SPEC_LENGTH // 5)) + "])"
    assert len(spec) > MAX_SPEC_LENGTH
    with pytest.raises(SpecError, match=f"holds {len(spec)} characters; at most"):
        parse(spec)
    assert parse(spec[: MAX_SPEC_LENGTH - 2].rpartition(",")[0] + "])").channels > 10_000


@pytest.mark.parametrize("spec", ["lambertian(", "lambertian +", "0.5 ** lambertian)", ""])
def test_syntax_errors_quote_the_spec(spec):
    with pytest.raises(ValueError, match="not a valid model expression") as info:
        parse(spec)
    assert repr(spec) in str(info.value)


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("__import__('os').system('exit 1')", "not allowed here"),
        ("open('/tmp/brdfkit-spec-test', 'w')", "unknown model 'open'"),
        ("lambertian.__class__", "not allowed here"),
        ("(lambda: 0)()", "not allowed here"),
        ("[lambertian for x in (1,)]", "not allowed here"),
        ("lambertian(albedo=__builtins__)", "not allowed here"),
        ("lambertian(albedo=f'{1}')", "not allowed here"),
        ("lambertian(**{'albedo': 0.5})", "not allowed here"),
        ("lambertian(0.5)", "takes parameters by name"),
        ("lambertian(albedo=1, albedo=0.5)", "given twice"),
        ("lambertian - lambertian", "not allowed here"),
        ("lambertian * lambertian", r"'\*' between a number"),
        ("1 + lambertian", "'\\+' between two models"),
        ("'a' * lambertian", r"'\*' between a number"),
        ("[0.5, 'a'] * lambertian", "list of numbers"),
        ("lambertian(albedo=-'a')", "sign before a number"),
        ("0.5", "is a value"),
        ("__import__('os').system('touch /tmp/brdfkit-spec-test')", "not allowed here"),
        ("lambertian(albedo=__import__('os').getpid())", "not allowed here"),
        ("().__class__.__bases__[0].__subclasses__()", "not allowed here"),
        ("lambertian(albedo=(lambda: 0.5)())", "not allowed here"),
        ("lambertian(albedo=[x for x in (0.5,)])", "not allowed here"),
        ("lambertian(albedo={0.5})", "not allowed here"),
        ("lambertian(albedo={'a': 0.5})", "not allowed here"),
        ("lambertian(albedo=f'{0.5}')", "not allowed here"),
        ("lambertian(albedo=(x := 0.5))", "not allowed here"),
        ("9**9**9", "not allowed here"),
        ("9**9**9 * lambertian", "not allowed here"),
        ("lambertian(albedo=[0.5][0])", "not allowed here"),
        ("lambertian(albedo=[*[0.5]])", "not allowed here|list of numbers"),
        ("lambertian(*[0.5])", "takes parameters by name"),
        ("lambertian(albedo=0.5 if 1 else 0.2)", "not allowed here"),
        ("lambertian(albedo=1j)", "not allowed here"),
        ("lambertian(albedo=b'0.5')", "not allowed here"),
        ("lambertian(albedo=...)", "not allowed here"),
        ("lambertian(albedo=[[0.5]])", "list of numbers"),
        ("lambertian(albedo=[])", "list of numbers"),
        ("lambertian(albedo=lambertian)", "not allowed here"),
        ("lambertian(albedo=0.5) and ggx", "not allowed here"),
        ("ggx < lambertian", "not allowed here"),
        ("lambertian(albedo=~1)", "not allowed here"),
        ("lambertian(albedo=" + "9" * 5000 + ")", "not a valid model expression"),
        ("lamb\x00ertian", "not a valid model expression"),
        (r"lambertian(albedo='\x00')", "rho must be a real number"),
        ("lamb\udc80ertian", "not a valid model expression"),
        (r"lambertian(material='\udcff')", "has no parameter"),
        (r"ggx(material='\udcff')", "material must be"),
        ("lambertian # comment", None),
        ("lambertian;ggx", "not a valid model expression"),
        ("lambertian\nggx", "not a valid model expression"),
        ("async def f(): pass", "not a valid model expression"),
        ("await lambertian", "not allowed here|not a valid model expression"),
        ("yield lambertian", "not a valid model expression"),
    ],
)
def test_anything_outside_the_grammar_is_rejected_without_running(spec, match, tmp_path):
    if match is None:  # a comment is no code: the spec is the model before it
        assert isinstance(parse(spec), Lambertian)
        return
    with pytest.raises((SpecError, ParameterError), match=match) as info:
        parse(spec)
    assert len(str(info.value)) < 1000  # the spec is quoted shortened
    assert not os.path.exists("/tmp/brdfkit-spec-test")


def test_grammar_errors_are_spec_errors_and_values_are_parameter_errors():
    for spec in ("lambertain", "lambertian(sigma=1)", "lambertian(", "lambertian - ggx", "0.5"):
        with pytest.raises(SpecError):
            parse(spec)
    with pytest.raises(ParameterError):
        parse("lambertian(albedo=-1)")


def test_a_spec_must_be_a_string():
    with pytest.raises(SpecError, match="spec must be a string; got Lambertian"):
        parse(Lambertian())
    for value in (None, 1, b"lambertian", ["lambertian"]):
        with pytest.raises(SpecError, match="spec must be a string"):
            parse(value)


def test_a_sum_samples_torch_directions_with_numpy_uniforms():
    torch = pytest.importorskip("torch")
    model = parse("lambertian(rho=0.3) + ggx(alpha=0.2)")
    wo = torch.tensor([[0.3, 0.1, 0.9], [0.0, 0.6, 0.8]], dtype=torch.float64)
    wo = wo / torch.linalg.vector_norm(wo, dim=-1, keepdim=True)
    u = np.random.default_rng(0).random((2, 3))
    mixed, same = model.sample(wo, u), model.sample(wo, torch.from_numpy(u))
    assert isinstance(mixed.wi, torch.Tensor)
    assert torch.equal(mixed.wi, same.wi) and torch.equal(mixed.weight, same.weight)


def test_a_long_chain_is_refused_whatever_the_recursion_limit():
    import sys

    from brdfkit.brdf.spec import MAX_CHAIN

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(20_000)  # IPython (which anywidget imports) raises it to 3000
    try:
        assert len(parse(" + ".join(["lambertian"] * MAX_CHAIN)).lobes) == MAX_CHAIN
        with pytest.raises(SpecError, match="chained too deeply"):
            parse(" + ".join(["lambertian"] * (MAX_CHAIN + 1)))
    finally:
        sys.setrecursionlimit(limit)
