"""The model spec language: round trips through to_spec, composition, and safe error handling."""

from __future__ import annotations

import math

import numpy as np
import pytest

import brdfkit.brdf  # noqa: F401  (registers every model)
from brdfkit.brdf._spec import parse
from brdfkit.brdf.base import MODELS, Scaled, Sum
from brdfkit.brdf.lambertian import Lambertian
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
    with pytest.raises(ValueError, match=r"lambertian: rho must be in \[0.0, 1.0\]; got 2"):
        parse("lambertian(albedo=2)")


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
    ],
)
def test_anything_outside_the_grammar_is_rejected_without_running(spec, match):
    with pytest.raises(ValueError, match=match):
        parse(spec)


def test_a_spec_must_be_a_string():
    with pytest.raises(ValueError, match="spec must be a string; got Lambertian"):
        parse(Lambertian())


def test_a_sum_samples_torch_directions_with_numpy_uniforms():
    torch = pytest.importorskip("torch")
    model = parse("lambertian(rho=0.3) + ggx(alpha=0.2)")
    wo = torch.tensor([[0.3, 0.1, 0.9], [0.0, 0.6, 0.8]], dtype=torch.float64)
    wo = wo / torch.linalg.vector_norm(wo, dim=-1, keepdim=True)
    u = np.random.default_rng(0).random((2, 3))
    mixed, same = model.sample(wo, u), model.sample(wo, torch.from_numpy(u))
    assert isinstance(mixed.wi, torch.Tensor)
    assert torch.equal(mixed.wi, same.wi) and torch.equal(mixed.weight, same.weight)
