"""BRDFs as JSON trees that the explorer's sliders edit, built back through the spec parser.

A tree is what the front end holds for one analytic BRDF::

    {"model": "ggx", "params": {"alpha": 0.2, "material": "Au"}}
    {"sum": [tree, tree, ...]}
    {"scaled": 0.5, "inner": tree}        # k * model; k a number or a list per channel

:func:`tree_of` turns a BRDF into its tree (and :func:`controls_of` lists each parameter with the
slider its :class:`~brdfkit.params.Domain` declares); :func:`brdf_of` writes a tree as a spec
string and reads it with :func:`brdfkit.brdf.parse`, so that the parser's validation (names,
types, domains) is the only one, and a tree can never run code.

References
----------
.. [1] B. Burley, "Physically-based shading at Disney" (BRDF Explorer's parameter sliders),
       SIGGRAPH 2012 course notes.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from brdfkit.brdf.base import BRDF, MODELS, SCALE, Scaled, Sum, spec_value
from brdfkit.brdf.spec import parse
from brdfkit.errors import SpecError
from brdfkit.fresnel import CONDUCTORS
from brdfkit.params import MAX_SPEC_LENGTH, Domain, parameter_domains

MAX_DEPTH = 16
"""The deepest tree :func:`brdf_of` reads (sums and scales nested)."""

MAX_NODES = 64
"""The most nodes (models, sums, scales) in one tree."""

LOG_FLOOR = 1e-3
"""The lower end of a log-scale slider whose domain starts at 0 (a cosine exponent)."""


def tree_of(brdf: BRDF) -> dict[str, Any]:
    """The JSON tree of ``brdf`` (a registered model, a sum or a scaled model).

    Raises
    ------
    SpecError
        For a model with no spec form (a measured table, a spatially varying parameter).

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> tree = tree_of(parse("lambertian(rho=0.5) + 0.5 * ggx(alpha=0.2)"))
    >>> tree["sum"][0]
    {'model': 'lambertian', 'params': {'rho': 0.5, 'allow_unphysical': False}}
    >>> tree["sum"][1]["scaled"], tree["sum"][1]["inner"]["params"]["alpha"]
    (0.5, 0.2)
    """
    if isinstance(brdf, Sum):
        return {"sum": [tree_of(lobe) for lobe in brdf.lobes]}
    if isinstance(brdf, Scaled):
        return {"scaled": _json_value(brdf.k), "inner": tree_of(brdf.inner)}
    if not brdf.spec_name or MODELS.get(brdf.spec_name) is not type(brdf):
        raise SpecError(f"{type(brdf).__name__} has no spec form to edit")
    return {
        "model": brdf.spec_name,
        "params": {k: _json_value(v) for k, v in brdf.params().items()},
    }


def _json_value(value: Any) -> Any:
    """A parameter value as JSON: a float, a list of floats, a string, a bool or ``None``."""
    if value is None or isinstance(value, str | bool):
        return value
    text = spec_value(value)  # raises for spatially varying values
    return parse_number_text(text)


def parse_number_text(text: str) -> float | list[float]:
    """A number or ``[a, b, c]`` written by :func:`~brdfkit.brdf.base.spec_value`.

    Examples
    --------
    >>> parse_number_text("0.5"), parse_number_text("[0.8, 0.5, 0.2]")
    (0.5, [0.8, 0.5, 0.2])
    """
    if text.startswith("["):
        return [float(x) for x in text[1:-1].split(",")]
    return float(text)


def spec_of(tree: Any) -> str:
    """The spec string of a tree (see the module docstring); checks its shape only.

    Raises
    ------
    SpecError
        For a node of no known form, a value that is no number, list, string, bool or ``None``,
        a tree deeper than :data:`MAX_DEPTH` or larger than :data:`MAX_NODES`.

    Examples
    --------
    >>> spec_of({"sum": [{"model": "lambertian", "params": {"rho": 0.3}}, {"model": "ggx"}]})
    '(lambertian(rho=0.3)) + (ggx())'
    >>> print(spec_of({"model": "lambertian", "params": {"rho": "__import__('os')"}}))  # no code
    lambertian(rho="__import__('os')")
    """
    count = [0]
    text = _spec(tree, 0, count)
    if len(text) > MAX_SPEC_LENGTH:
        raise SpecError(
            f"the model tree's spec holds {len(text)} characters; at most {MAX_SPEC_LENGTH}"
        )
    return text


def _spec(node: Any, depth: int, count: list[int]) -> str:
    count[0] += 1
    if depth > MAX_DEPTH or count[0] > MAX_NODES:
        raise SpecError(f"a model tree holds at most {MAX_NODES} nodes, {MAX_DEPTH} deep")
    if not isinstance(node, dict):
        raise SpecError(f"a model tree node must be an object; got {type(node).__name__}")
    if set(node) == {"sum"} and isinstance(node["sum"], list) and node["sum"]:
        return " + ".join(f"({_spec(n, depth + 1, count)})" for n in node["sum"])
    if set(node) == {"scaled", "inner"}:
        return f"{_literal(node['scaled'])} * ({_spec(node['inner'], depth + 1, count)})"
    if set(node) <= {"model", "params"} and isinstance(node.get("model"), str):
        params = node.get("params", {})
        if not isinstance(params, dict) or not all(isinstance(k, str) for k in params):
            raise SpecError("a model's params must be an object of name: value")
        for key in params:
            if not key.isidentifier():
                raise SpecError(f"parameter name {key[:40]!r} is not a name")
        if not node["model"].isidentifier():
            raise SpecError(f"model name {node['model'][:40]!r} is not a name")
        args = ", ".join(f"{k}={_literal(v)}" for k, v in params.items())
        return f"{node['model']}({args})"
    raise SpecError(
        "a model tree node must be {model, params}, {sum: [...]} or {scaled, inner}; got keys "
        f"{sorted(map(str, node))[:6]}"
    )


def _literal(value: Any) -> str:
    """A JSON value as spec text (strings quoted by ``repr``: never code)."""
    if value is None or isinstance(value, bool):
        return str(value)
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, int | float) and _finite_float(value) is not None:
        return repr(float(value))
    if (
        isinstance(value, list)
        and value
        and all(isinstance(x, int | float) and not isinstance(x, bool) for x in value)
    ):
        return "[" + ", ".join(_literal(x) for x in value) + "]"
    raise SpecError(
        f"a parameter value must be a finite number, a list of them, a string, a bool "
        f"or null; got {type(value).__name__} {str(value)[:40]}"
    )


def _finite_float(value: int | float) -> float | None:
    """``float(value)`` when finite; ``None`` for NaN, infinity or an integer beyond the float
    range (``float(10**400)`` overflows)."""
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def brdf_of(tree: Any) -> BRDF:
    """The BRDF a tree describes, built by the spec parser (its errors propagate).

    Examples
    --------
    >>> brdf_of({"model": "lambertian", "params": {"rho": 0.3}})
    Lambertian(rho=0.3, allow_unphysical=False)
    """
    return parse(spec_of(tree))


def slider(domain: Domain) -> dict[str, Any]:
    """The slider a domain declares: ``{lo, hi, log}`` with finite ends (a log slider's lower
    end is positive, :data:`LOG_FLOOR` at most, for a domain that starts at 0).

    Examples
    --------
    >>> from brdfkit.params import Domain
    >>> slider(Domain(0.0, 1.0, hint="an albedo"))
    {'lo': 0.0, 'hi': 1.0, 'log': False, 'hint': 'an albedo'}
    >>> slider(Domain(1e-4, 10.0, log=True))["log"]
    True
    """
    lo, hi = domain.lo, domain.hi
    log = domain.log or (lo >= 0 and hi / max(lo, LOG_FLOOR) > 1e4)
    if log:
        lo = lo if lo > 0 else min(LOG_FLOOR, hi * 1e-6)
    return {"lo": lo, "hi": hi, "log": log, "hint": domain.hint}


def controls_of(brdf: BRDF) -> list[dict[str, Any]]:
    """One record per editable parameter of ``brdf``'s tree, in order: ``path`` (the list of
    keys and indices that reach its value in :func:`tree_of`), ``name``, ``model``, ``kind``
    (``"number"``, ``"rgb"``, ``"bool"``, ``"choice"``, ``"text"``) and, for numbers, the
    ``slider``; for a choice, its ``options`` (:func:`options_of`: the page shows a menu).

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> for control in controls_of(parse("lambertian(rho=0.5)")):
    ...     print(control["name"], control["kind"], control["path"])
    rho number ['params', 'rho']
    allow_unphysical bool ['params', 'allow_unphysical']
    """
    controls: list[dict[str, Any]] = []
    _controls(brdf, [], controls)
    return controls


def _controls(brdf: BRDF, path: list[Any], out: list[dict[str, Any]]) -> None:
    if isinstance(brdf, Sum):
        for i, lobe in enumerate(brdf.lobes):
            _controls(lobe, [*path, "sum", i], out)
        return
    if isinstance(brdf, Scaled):
        out.append(_control("k", brdf.k, SCALE, "scale", [*path, "scaled"]))
        _controls(brdf.inner, [*path, "inner"], out)
        return
    domains = parameter_domains(type(brdf))
    for f in dataclasses.fields(brdf):  # type: ignore[arg-type]
        if f.init:
            value = getattr(brdf, f.name)
            control = _control(
                f.name, value, domains.get(f.name), brdf.spec_name, [*path, "params", f.name]
            )
            options = options_of(type(brdf), f.name)
            if options and control["kind"] == "text" and value in options:
                control |= {"kind": "choice", "options": list(options)}
            out.append(control)


def options_of(model: type[BRDF], name: str) -> tuple[str, ...]:
    """The values the string parameter ``name`` of ``model`` may take (its menu), or ``()``:
    the options its classes declare (:attr:`BRDF.choices`, merged over the bases), the one
    distribution a model fixes (``ggx``, ``beckmann``), and for a ``material`` whose default
    is ``"none"`` (a conductor preset) ``"none"`` and the metals of
    :data:`brdfkit.fresnel.CONDUCTORS`.

    Examples
    --------
    >>> from brdfkit.brdf.base import MODELS
    >>> options_of(MODELS["ggx"], "distribution"), options_of(MODELS["ggx"], "masking")[:2]
    (('ggx',), ('v_groove', 'smith_separable'))
    >>> options_of(MODELS["ggx"], "material")[:3], options_of(MODELS["ggx"], "alpha")
    (('none', 'Ag', 'Al'), ())
    """
    declared: dict[str, tuple[str, ...]] = {}
    for klass in reversed(model.__mro__):
        declared.update(vars(klass).get("choices", {}))
    fixed = getattr(model, f"{name}_name", None)
    if isinstance(fixed, str):
        return (fixed,)
    if name in declared:
        return tuple(declared[name])
    fields = {f.name: f for f in dataclasses.fields(model)}  # type: ignore[arg-type]
    if name == "material" and name in fields and fields[name].default == "none":
        return ("none", *CONDUCTORS)
    return ()


def _control(
    name: str, value: Any, domain: Domain | None, model: str, path: list[Any]
) -> dict[str, Any]:
    record: dict[str, Any] = {"path": path, "name": name, "model": model}
    json_value = None if value is None or isinstance(value, str | bool) else _json_value(value)
    if isinstance(value, bool):
        record["kind"] = "bool"
    elif domain is not None and isinstance(json_value, float):
        record |= {"kind": "number", "slider": slider(domain)}
    elif domain is not None and isinstance(json_value, list) and len(json_value) == 3:
        record |= {"kind": "rgb", "slider": slider(domain)}
    else:
        record["kind"] = "text"
    return record


__all__ = [
    "LOG_FLOOR",
    "MAX_DEPTH",
    "MAX_NODES",
    "brdf_of",
    "controls_of",
    "options_of",
    "slider",
    "spec_of",
    "tree_of",
]
