"""Parameters: the domains numeric parameters may take, their checks, and their arrays.

Models (:mod:`brdfkit.brdf`) and lights (:mod:`brdfkit.light`) declare each numeric parameter's
:class:`Domain` in a class attribute ``domains``; :func:`check_domains` checks an instance
against them with messages that name the parameter, its value and the allowed range, and
:func:`param` turns a parameter into an array in the namespace, dtype and device of the inputs
(parameters broadcast against ``batch + (C,)``).
"""

from __future__ import annotations

import dataclasses
import math
import reprlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit._array import Array, asarray, check_param, is_abstract, namespace
from brdfkit.errors import ParameterError

# --------------------------------------------------------------------------- validation
_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 40
_SHORT.maxlist = _SHORT.maxtuple = 6


def described(value: Any) -> str:
    """``value`` for an error message: its type and a shortened repr."""
    return f"{type(value).__name__} {_SHORT.repr(value)}"


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """Raise :class:`~brdfkit.errors.ParameterError` naming ``name`` unless ``value`` is one of
    the strings ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise ParameterError(f"{name} must be one of {choices}; got {described(value)}")
    return value


def check_flag(name: str, value: Any) -> bool:
    """Raise :class:`~brdfkit.errors.ParameterError` naming ``name`` unless ``value`` is a bool."""
    if not isinstance(value, bool | np.bool_):
        raise ParameterError(f"{name} must be True or False; got {described(value)}")
    return bool(value)


def check_number(name: str, value: Any) -> Any:
    """Raise :class:`~brdfkit.errors.ParameterError` naming ``name`` unless ``value`` is a real
    number or a non-empty array of them (a list, a NumPy, PyTorch or JAX array), not a bool.

    Strings, ``None``, booleans, complex numbers, empty and ragged lists are refused; the value
    is returned unchanged.
    """
    if hasattr(value, "dtype") and hasattr(value, "shape") and not isinstance(value, np.generic):
        xp = namespace(value)
        real = xp.isdtype(value.dtype, ("real floating", "integral"))
        if real and (is_abstract(value) or math.prod(value.shape) > 0):
            return value
    elif isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_
    ):
        return value
    elif isinstance(value, list | tuple | np.generic):
        try:
            array = np.asarray(value)
        except (ValueError, TypeError):  # ragged nesting
            array = None
        if array is not None and array.dtype.kind in "iuf" and array.size > 0:
            return value
    raise ParameterError(
        f"{name} must be a real number or a non-empty array of real numbers; got {described(value)}"
    )


@dataclass(frozen=True)
class Domain:
    """The interval a numeric parameter may take: ``[lo, hi]`` (either end open).

    Every numeric parameter of a model is checked against one declared domain, in which its
    formulas are finite (the class attribute ``domains`` of a model or light, read by
    :func:`parameter_domains`). ``unphysical_hi`` is the upper end when the model's
    ``allow_unphysical`` switch is on (``None``: the switch does not widen it). ``log`` says that
    the parameter is best varied on a logarithmic scale (roughness, exponents: the explorer's
    sliders read it).

    Examples
    --------
    >>> albedo = Domain(0.0, 1.0, hint="an albedo", unphysical_hi=1e6)
    >>> albedo.check("rho", 0.5)
    0.5
    >>> albedo.check("rho", 3.0, unphysical=True)
    3.0
    >>> albedo.check("rho", 1.5)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: rho must be in [0.0, 1.0]; got 1.5 (an albedo; pass ...)
    >>> Domain(0.0, 1.0, lo_open=True).check("alpha", "rough")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: alpha must be a real number or ...; got str 'rough'
    """

    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False
    hint: str = ""
    unphysical_hi: float | None = None
    log: bool = False

    def check(self, name: str, value: Any, *, unphysical: bool = False) -> Any:
        """``value`` unchanged if it is a number (or array) inside the domain.

        Raises
        ------
        brdfkit.errors.ParameterError
            Naming ``name``, the value and the domain (``"alpha must be in [0.0001, 10.0];
            got 1e+308"``), or the type for a value that is no number.
        """
        check_number(name, value)
        hi = self.unphysical_hi if unphysical and self.unphysical_hi is not None else self.hi
        hint = self.hint
        if not unphysical and self.unphysical_hi is not None:
            hint = f"{hint}; " if hint else ""
            hint += "pass allow_unphysical=True for more"
        return check_param(
            name, value, self.lo, hi, lo_open=self.lo_open, hi_open=self.hi_open, hint=hint
        )


UNPHYSICAL_MAX = 1e6
"""The upper end of colour and scale parameters beyond physics (``allow_unphysical=True``, the
factor ``k`` of ``k * model``): data in arbitrary units, far from any float overflow."""


def parameter_domains(cls: type) -> dict[str, Domain]:
    """The declared :class:`Domain` of each numeric parameter of the model class ``cls``.

    Read from the class attribute ``domains`` of ``cls`` and of its bases (a
    subclass's entry overrides its base's), the one declaration that validation
    (:func:`check_domains`), ``brdfkit models`` and the explorer's sliders share.

    Parameters
    ----------
    cls : a dataclass with a class attribute ``domains`` (a model, a light).

    Returns
    -------
    dict
        Parameter name to its domain, in the order of the dataclass fields; parameters that
        are no numbers (options, flags) are absent.

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> parameter_domains(Lambertian)["rho"].hi
    1.0
    """
    declared: dict[str, Domain] = {}
    for klass in reversed(cls.__mro__):
        declared.update(vars(klass).get("domains", {}))
    order = {f.name: i for i, f in enumerate(dataclasses.fields(cls))}
    return dict(sorted(declared.items(), key=lambda item: order.get(item[0], len(order))))


def check_domains(model: Any) -> None:
    """Check every numeric parameter of ``model`` against its declared domain
    (:func:`parameter_domains`).

    An optional parameter (one whose default is ``None``) that is ``None`` is not checked; a
    model with an ``allow_unphysical`` switch has it checked first, and when it is on, domains
    with an ``unphysical_hi`` reach up to that. Cross-parameter conditions (ρd + ρs ≤ 1, the
    Fresnel options) stay with each model.

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming the first parameter (in field order) that is no number or lies outside its
        domain, or ``allow_unphysical`` when it is no bool.

    Examples
    --------
    Models call it at construction:

    >>> from brdfkit.brdf import Lambertian
    >>> Lambertian(rho=1.5)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: rho must be in [0.0, 1.0]; got 1.5 ...
    """
    cls = type(model)
    optional = {f.name for f in dataclasses.fields(cls) if f.default is None}
    unphysical = hasattr(model, "allow_unphysical") and check_flag(
        "allow_unphysical", model.allow_unphysical
    )
    for name, domain in parameter_domains(cls).items():
        value = getattr(model, name)
        if value is not None or name not in optional:
            domain.check(name, value, unphysical=unphysical)


def channel_count(*values: Any, names: tuple[str, ...] = ()) -> int:
    """The channel count C implied by channel-valued parameters (their trailing axis).

    Scalars count as 1 and broadcast to any C; two parameters with different trailing sizes > 1
    are a :class:`~brdfkit.errors.ParameterError` that names both.

    Examples
    --------
    >>> channel_count(0.5, [0.8, 0.5, 0.2])
    3
    >>> channel_count([0.8, 0.5, 0.2], [0.1, 0.2], names=("rho", "k"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: k has 2 channels but rho has 3; ...
    """
    count, owner = 1, None
    for i, value in enumerate(values):
        shape = tuple(value.shape) if hasattr(value, "shape") else np.shape(value)
        c = shape[-1] if shape else 1
        if c == 1:
            continue
        if count not in (1, c):
            this = names[i] if i < len(names) else f"parameter {i}"
            raise ParameterError(
                f"{this} has {c} channels but {owner} has {count}; channel-valued parameters "
                "must share their last axis (or have length 1)"
            )
        count, owner = c, names[i] if i < len(names) else f"parameter {i}"
    return count


def param(value: Any, like: Array) -> Array:
    """A parameter as an array in the namespace, dtype and device of ``like``, at least 1-d.

    Parameters broadcast against ``batch + (C,)``: a scalar becomes shape ``(1,)``. They take
    the directions' floating dtype, so float32 inputs compute in float32 end to end (a float64
    parameter is rounded; a torch parameter keeps its autograd graph through the cast).

    Examples
    --------
    >>> import numpy as np
    >>> value = param(0.5, np.zeros(3, dtype=np.float32))
    >>> value.shape, value.dtype
    ((1,), dtype('float32'))
    """
    if type(value) is float and type(like) is np.ndarray and like.dtype.kind == "f":
        return np.array([value], dtype=like.dtype)  # the common case, before the general rules
    xp = namespace(like, value)
    native = hasattr(like, "dtype") and namespace(like) is xp  # not NumPy beside a tensor
    floating = native and xp.isdtype(like.dtype, "real floating")
    arr = asarray(value, xp, like=like, dtype=like.dtype if floating else None)
    return xp.reshape(arr, (1,)) if arr.ndim == 0 else arr


MAX_SPEC_LENGTH = 100_000
"""The longest model or light spec string brdfkit reads, in characters (a spatially varying
model has no spec; a spectral one with a few thousand values per parameter fits)."""


__all__ = [
    "MAX_SPEC_LENGTH",
    "UNPHYSICAL_MAX",
    "Domain",
    "channel_count",
    "check_choice",
    "check_domains",
    "check_flag",
    "check_number",
    "param",
    "parameter_domains",
]
