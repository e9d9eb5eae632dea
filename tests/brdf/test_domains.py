"""Every parameter of every registered model has a domain in which the model is finite.

For each model and each parameter, extreme and wrong-typed values either raise
:class:`~brdfkit.errors.ParameterError` at construction, naming the parameter, or give a model
whose ``eval`` is finite and non-negative and whose ``pdf``, sample weights, sampling weight and
albedo are finite, on a few hundred random direction pairs, in float64 and float32.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from brdfkit.brdf import MODELS
from brdfkit.brdf.base import BRDF
from brdfkit.errors import ParameterError
from brdfkit.params import parameter_domains
from brdfkit.sampling import square_to_uniform_hemisphere

EXTREMES = [
    1e308, -1e308, 1e-320, -1e-320, 0, -0.0, math.nan, math.inf, -math.inf, 1e6, -1e6, 1e-12,
    1e30, 0.5, 2.0, [0.5] * 300, [1e308] * 300, np.float32(3e38),
]  # fmt: skip
"""Values every numeric parameter meets: each either raises ParameterError or works."""

WRONG_NUMBERS = ["0.5", "abc", True, False, [], [[]], [[0.5], [0.5, 0.3]], [0.5, "a"], {}, 1j]
"""Values of the wrong type for a numeric parameter: always a ParameterError."""

WRONG_STRINGS = [2, 2.5, True, ["ggx"], b"ggx", 0.0, np.nan]
"""Values of the wrong type for a string option: always a ParameterError."""

WRONG_FLAGS = [1, 0, "yes", "True", [True], 0.5, np.nan]
"""Values of the wrong type for a boolean switch: always a ParameterError."""

COMPANIONS = {"alpha_u": {"alpha_v": 0.2}, "alpha_v": {"alpha_u": 0.2}, "k": {"eta": 1.5}}
"""Parameters that only take effect together with another."""

EDGE_COMPANIONS = {
    "kd": {"ks": 0.0},
    "ks": {"kd": 0.0},
    "cx": {"n": (1.0,)},
    "cy": {"n": (1.0,)},
    "cz": {"n": (1.0,)},
}
"""What a parameter needs beside it to stand at an end of its domain: the other albedo 0 (so
that ρd + ρs ≤ 1), a Lafortune lobe of exponent 1 (so that its peak stays bounded)."""


def _fields(cls: type[BRDF], kind: str) -> list[str]:
    """The init fields of ``cls`` annotated as ``kind`` ("Any": numeric, "bool", "str")."""
    return [
        f.name
        for f in dataclasses.fields(cls)  # type: ignore[arg-type]
        if f.init and kind in str(f.type).replace("| None", "").split()
    ]


def _variants(cls: type[BRDF]) -> list[dict]:
    """The defaults, and each other value of each string option (one at a time)."""
    variants = [{}]
    for name, choices in _choices(cls).items():
        variants += [{name: choice} for choice in choices]
    return variants


def _choices(cls: type[BRDF]) -> dict[str, tuple[str, ...]]:
    """The string options of ``cls`` that change the formulas, with their alternatives."""
    options = {
        "masking": ("v_groove", "smith_separable", "smith_correlated"),
        "model": ("full",),
        "normalization": ("rtr", "ward", "duer"),
        "fresnel": ("none", "dielectric", "conductor", "schlick"),
        "distribution": ("beckmann",),
        "mode": ("importance",),
    }
    fields = _fields(cls, "str")
    out = {}
    for name, choices in options.items():
        if name not in fields:
            continue
        valid = []
        for choice in choices:
            try:
                cls(**{name: choice})
            except ParameterError:
                continue
            valid.append(choice)
        out[name] = tuple(valid)
    return out


def _pairs(n: int = 256, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u = np.random.default_rng(seed).random((3, n, 3))
    return (
        square_to_uniform_hemisphere(u[0, :, :2]),
        square_to_uniform_hemisphere(u[1, :, :2]),
        u[2],
    )


def assert_finite(model: BRDF, dtype: type = np.float64, pairs: int = 256) -> None:
    """``eval`` finite and ≥ 0, ``pdf``, samples, sampling weight and albedo finite on
    ``pairs`` random direction pairs."""
    wi, wo, u = (a.astype(dtype) for a in _pairs(pairs))
    with np.errstate(all="ignore"):  # only the results count, not how they were reached
        f = np.asarray(model.eval(wi, wo))
        pdf = np.asarray(model.pdf(wi, wo))
        s = model.sample(wo, u)
        weight = model.sampling_weight(wo)
        albedo = model.albedo(wo[:4], samples=32)
    assert np.all(np.isfinite(f)) and np.all(f >= 0), f"eval of {model!r}: {f[~(f >= 0)][:3]}"
    assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0), f"pdf of {model!r}"
    for name, value in (("sample weight", s.weight), ("sample pdf", s.pdf), ("wi", s.wi)):
        assert np.all(np.isfinite(np.asarray(value))), f"{name} of {model!r}"
    assert np.all(np.isfinite(np.asarray(weight))), f"sampling weight of {model!r}"
    assert np.all(np.isfinite(np.asarray(albedo))), f"albedo of {model!r}"


def _build(cls: type[BRDF], variant: dict, name: str, value: object) -> BRDF | None:
    """``cls`` with ``name=value``, or None when it raises ParameterError naming ``name``."""
    kwargs = {**variant, **COMPANIONS.get(name, {}), name: value}
    try:
        return cls(**kwargs)
    except ParameterError as error:
        assert name in str(error), f"{cls.spec_name}({kwargs}): {error}"
        return None


NUMERIC = [
    pytest.param(cls, name, id=f"{spec}.{name}")
    for spec, cls in sorted(MODELS.items())
    for name in _fields(cls, "Any")
]


@pytest.mark.parametrize(("cls", "name"), NUMERIC)
def test_extreme_values_raise_or_stay_finite(cls, name):
    for variant in _variants(cls):
        for value in EXTREMES:
            model = _build(cls, variant, name, value)
            if model is None:
                continue
            if isinstance(value, list):  # 300 channels: fewer pairs keep it quick
                assert_finite(model, pairs=32)
            else:
                assert_finite(model)
                assert_finite(model, np.float32)


@pytest.mark.parametrize(("cls", "name"), NUMERIC)
def test_wrong_types_of_numbers_raise_a_parameter_error(cls, name):
    default = next(f.default for f in dataclasses.fields(cls) if f.name == name)
    for value in WRONG_NUMBERS + ([None] if default is not None else []):
        with pytest.raises(ParameterError, match=name):
            cls(**{**COMPANIONS.get(name, {}), name: value})


@pytest.mark.parametrize(
    ("cls", "name", "kind"),
    [
        pytest.param(cls, name, kind, id=f"{spec}.{name}")
        for spec, cls in sorted(MODELS.items())
        for kind in ("str", "bool")
        for name in _fields(cls, kind)
    ],
)
def test_wrong_types_of_options_raise_a_parameter_error(cls, name, kind):
    for value in WRONG_STRINGS if kind == "str" else WRONG_FLAGS:
        with pytest.raises(ParameterError, match=name):
            cls(**{name: value})
    if kind == "str":
        with pytest.raises(ParameterError, match=name):
            cls(**{name: "no such option"})


def test_the_reported_cases_raise():
    for spec, kwargs in (
        ("ggx", {"alpha": 1e308}),
        ("blinn_phong", {"n": 1e308}),
        ("torrance_sparrow", {"m": 1e-320}),
        ("ggx", {"material": 2}),
    ):
        with pytest.raises(ParameterError, match=f"{next(iter(kwargs))} must be"):
            MODELS[spec](**kwargs)


def _at_edge(cls: type[BRDF], name: str, value: float, **options: object) -> BRDF:
    """``cls`` with ``name=value`` (as a one-lobe tuple for a lobe-indexed parameter), beside
    the companions it needs there."""
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    companions = {**COMPANIONS.get(name, {}), **EDGE_COMPANIONS.get(name, {})}
    kwargs = {k: v for k, v in companions.items() if k in fields}
    lobed = isinstance(fields[name].default, tuple)
    return cls(**kwargs, **options, **{name: (value,) if lobed else value})


@pytest.mark.parametrize("cls", [pytest.param(c, id=s) for s, c in sorted(MODELS.items())])
def test_every_numeric_parameter_declares_its_domain(cls):
    assert list(parameter_domains(cls)) == _fields(cls, "Any")


@pytest.mark.parametrize(("cls", "name"), NUMERIC)
def test_validation_accepts_the_ends_of_the_declared_domain_and_nothing_beyond(cls, name):
    domain = parameter_domains(cls)[name]
    ends = [(domain.lo, domain.lo_open, -math.inf), (domain.hi, domain.hi_open, math.inf)]
    for end, is_open, outwards in ends:
        if is_open:
            with pytest.raises(ParameterError, match=f"{name} must be in"):
                _at_edge(cls, name, end)
        else:
            _at_edge(cls, name, end)
        with pytest.raises(ParameterError, match=f"{name} must be in"):
            _at_edge(cls, name, float(np.nextafter(end, outwards)))
    if domain.unphysical_hi is not None and "allow_unphysical" in _fields(cls, "bool"):
        _at_edge(cls, name, domain.unphysical_hi, allow_unphysical=True)
        beyond = float(np.nextafter(domain.unphysical_hi, math.inf))
        with pytest.raises(ParameterError, match=f"{name} must be in"):
            _at_edge(cls, name, beyond, allow_unphysical=True)
