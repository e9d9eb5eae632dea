"""BRDFs as the explorer's JSON trees, and the sliders their domains declare."""

from __future__ import annotations

import math

import pytest

from brdfkit.brdf import MODELS, parse
from brdfkit.brdf.base import EXPONENT, ROUGHNESS
from brdfkit.errors import SpecError
from brdfkit.explore.model_tree import brdf_of, controls_of, slider, spec_of, tree_of
from brdfkit.params import parameter_domains


@pytest.mark.parametrize(
    "spec",
    [
        "lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2, material='Au')",
        "0.7 * (lambertian + 0.5 * ggx(alpha=0.1))",
        "oren_nayar(sigma=0.3) + phong(n=40, ks=0.2)",
    ],
)
def test_a_tree_builds_the_same_brdf(spec):
    brdf = parse(spec)
    assert brdf_of(tree_of(brdf)).to_spec() == brdf.to_spec()


def test_every_registered_model_round_trips_and_has_sliders():
    for name, cls in MODELS.items():
        brdf = cls()
        assert brdf_of(tree_of(brdf)).to_spec() == brdf.to_spec(), name
        controls = controls_of(brdf)
        for c in controls:
            if c["kind"] == "number":
                s = c["slider"]
                assert math.isfinite(s["lo"]) and math.isfinite(s["hi"]) and s["lo"] < s["hi"]
                assert not s["log"] or s["lo"] > 0
        numbers = {c["name"] for c in controls if c["kind"] in ("number", "rgb")}
        assert numbers <= set(parameter_domains(cls)), name


def test_log_sliders_come_from_the_declarations():
    assert ROUGHNESS.log and EXPONENT.log
    assert slider(ROUGHNESS) == {"lo": 1e-4, "hi": 10.0, "log": True, "hint": ROUGHNESS.hint}
    assert slider(EXPONENT)["lo"] > 0  # a log slider cannot start at 0
    alpha = next(c for c in controls_of(parse("ggx(alpha=0.2)")) if c["name"] == "alpha")
    assert alpha["slider"]["log"] and alpha["path"] == ["params", "alpha"]


@pytest.mark.parametrize(
    "tree",
    [
        {"model": "ggx", "params": {"alpha": "0.1); import os; ("}},  # a string, quoted
        {"model": "__import__", "params": {}},
        {"model": "ggx", "params": {"alpha": float("nan")}},
        {"model": "ggx", "params": {"x y": 1}},
        {"model": "ggx", "extra": 1},
        {"scaled": 0.5},
        {"sum": []},
        [1, 2],
    ],
)
def test_bad_trees_are_refused(tree):
    with pytest.raises(ValueError):
        brdf_of(tree)


def test_deep_or_large_trees_are_refused():
    tree = {"model": "lambertian", "params": {}}
    for _ in range(40):
        tree = {"scaled": 1.0, "inner": tree}
    with pytest.raises(SpecError, match="at most"):
        spec_of(tree)


def test_parameters_with_a_fixed_set_of_values_are_choices():
    from brdfkit.brdf.microfacet import MASKINGS
    from brdfkit.fresnel import CONDUCTORS

    controls = {c["name"]: c for c in controls_of(parse("rough_conductor(material='Au')"))}
    assert controls["distribution"]["kind"] == "choice"
    assert controls["distribution"]["options"] == ["ggx", "beckmann"]
    assert controls["masking"]["options"] == list(MASKINGS)
    assert controls["material"]["options"] == ["none", *CONDUCTORS]
    assert controls["alpha"]["kind"] == "number" and "options" not in controls["alpha"]
    # every option is a value the model accepts
    for name in ("distribution", "masking", "material"):
        for option in controls[name]["options"]:
            parse(f"rough_conductor({name}={option!r})")
    # a model that fixes its distribution offers that one only
    ggx = {c["name"]: c for c in controls_of(parse("ggx(alpha=0.2)"))}
    assert ggx["distribution"]["options"] == ["ggx"]
