"""A model as its *structure* and its *parameter values*, for kernels compiled once per structure.

The structure of a model is its spec tree with every numeric parameter (a field with a declared
:class:`~brdfkit.params.Domain`, and the factor ``k`` of ``k * model``) replaced by its shape:
the class of each node, its options (strings, flags, ``None``), nested lobes, and the shapes of
the parameters. Two models of one structure differ only in parameter values, so one compiled
kernel serves both, taking the values as an input (:mod:`brdfkit.compiled`).
:func:`rebuild` makes the model again from any values of the right shapes — traced arrays included,
which is how a kernel is traced once for the whole structure.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Hashable, Iterator
from typing import Any

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF, Scaled
from brdfkit.params import parameter_domains


def parameter_names(cls: type[BRDF]) -> frozenset[str]:
    """The fields of ``cls`` that are numeric parameters (values, not structure)."""
    names = set(parameter_domains(cls))
    if issubclass(cls, Scaled):
        names.add("k")
    return frozenset(names)


def _lobes(value: Any) -> bool:
    return isinstance(value, tuple) and len(value) > 0 and all(isinstance(v, BRDF) for v in value)


def _option_key(name: str, value: Any) -> Hashable:
    """A field that is structure, as a hashable key (its value)."""
    if value is None or isinstance(value, str | bool | int | float | complex | np.generic):
        return (name, type(value).__name__, value)
    if isinstance(value, np.ndarray):
        return (name, value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, tuple) and all(
        v is None or isinstance(v, str | bool | int | float) for v in value
    ):
        return (name, "tuple", value)
    raise TypeError(f"the field {name}={type(value).__name__} has no structure key")


def split(model: BRDF) -> tuple[Hashable, list[np.ndarray]]:
    """``(structure, values)``: a hashable key of the model's structure (module docstring) and
    its parameter values in a fixed order (depth first, fields in order).

    Raises
    ------
    TypeError
        When a field is neither a parameter, an option, nor lobes (it has no key).
    """
    values: list[np.ndarray] = []
    return _split(model, values), values


def _split(model: BRDF, values: list[np.ndarray]) -> Hashable:
    names = parameter_names(type(model))
    key: list[Hashable] = [type(model)]
    for field in dataclasses.fields(model):  # type: ignore[arg-type]
        if not field.init:
            continue
        value = getattr(model, field.name)
        if isinstance(value, BRDF):
            key.append((field.name, _split(value, values)))
        elif _lobes(value):
            key.append((field.name, tuple(_split(v, values) for v in value)))
        elif field.name in names and value is not None and not isinstance(value, bool):
            array = np.asarray(to_numpy(value))
            if array.dtype.kind not in "iuf":
                key.append(_option_key(field.name, value))
                continue
            values.append(array)
            key.append((field.name, "parameter", array.shape))
        else:
            key.append(_option_key(field.name, value))
    return tuple(key)


def rebuild(model: BRDF, values: Iterator[Any]) -> BRDF:
    """``model`` with its parameters, in :func:`split`'s order, taken from ``values`` (each of
    its parameter's shape); the model's own constructor runs on them."""
    names = parameter_names(type(model))
    changes: dict[str, Any] = {}
    for field in dataclasses.fields(model):  # type: ignore[arg-type]
        if not field.init:
            continue
        value = getattr(model, field.name)
        if isinstance(value, BRDF):
            changes[field.name] = rebuild(value, values)
        elif _lobes(value):
            changes[field.name] = tuple(rebuild(v, values) for v in value)
        elif field.name in names and value is not None and not isinstance(value, bool):
            if np.asarray(to_numpy(value)).dtype.kind in "iuf":
                changes[field.name] = next(values)
    return dataclasses.replace(model, **changes)  # type: ignore[type-var]


__all__ = ["parameter_names", "rebuild", "split"]
