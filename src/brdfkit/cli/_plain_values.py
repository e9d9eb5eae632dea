"""Command-line values that need no pydantic: strings, paths, and plainly written numbers.

typer (0.29, the release tested) converts every parameter value, a command's defaults
included, through a pydantic ``TypeAdapter``: the first conversion of a process imports
pydantic and builds an adapter per parameter, ~0.1 s of every command (a warm ``brdfkit
render`` spent 0.08-0.1 s there, more than loading its tile kernel). Most values a
command receives are already what the command takes: a string for ``str``, a path for
``Path``, a number written in decimal digits for ``int`` or ``float``. :func:`plain_values`
gives a command's parameters a converter that returns those at once, exactly as typer's
adapter would (``tests/cli/test_plain_values.py`` compares the two on every parameter of every
command), and hands every other value to typer's own converter, built on first use: its
result and its error message are typer's.

Everything here that knows typer's internals sits in this module, and it acts only with the
typer releases it is tested with (:data:`TESTED_TYPER`): with any other, :func:`plain_values`
leaves the command as it is, which converts as before, slower.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")
"""An integer as a user types it: ASCII digits, a sign (no spaces, underscores or exponent:
those go to typer, which accepts some of them)."""
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
"""A float as a user types it: decimal digits, a point, an exponent (``float()`` and
pydantic round it alike; ``inf``, ``nan`` and underscores go to typer)."""


TESTED_TYPER = ("0.29",)
"""The typer releases (major.minor) whose internals this module is tested with."""


def engaged() -> bool:
    """Whether the installed typer is one of :data:`TESTED_TYPER`."""
    import typer

    return ".".join(typer.__version__.split(".")[:2]) in TESTED_TYPER


class _Unconverted(Exception):
    """A value the plain conversion does not decide: typer's own converter takes it."""


def _within(number: Any, info: Any) -> Any:
    if (info.min is not None and not number >= info.min) or (
        info.max is not None and not number <= info.max
    ):
        raise _Unconverted  # typer's adapter words the error (or clamps)
    return number


def _leaf(annotation: Any, info: Any, value: Any, param: Any, ctx: Any) -> Any:
    """``value`` as ``annotation`` where it is plainly one, else :class:`_Unconverted`."""
    if (annotation is str and type(value) is str) or (annotation is bool and type(value) is bool):
        return value
    if annotation is int and type(value) is str and _INTEGER.fullmatch(value):
        return _within(int(value), info)
    if annotation is int and type(value) is int:
        return _within(value, info)
    if annotation is float and type(value) is str and _DECIMAL.fullmatch(value):
        return _within(float(value), info)
    if annotation is float and type(value) in (float, int):
        return _within(float(value), info)
    if annotation is Path and type(value) is str:
        value = Path(value)
    if annotation is Path and isinstance(value, Path):
        from typer._click.exceptions import BadParameter
        from typer._param_types import coerce_cli_path

        try:  # typer's own checks of a path (exists, readable, …), given a Path: no pydantic
            return coerce_cli_path(value, info, path_type=Path, param=param, ctx=ctx)
        except BadParameter:
            raise _Unconverted from None  # typer's adapter words the error, naming the text
    raise _Unconverted


class _PlainConverter:
    """A parameter's converter (typer's ``RuntimeParam`` interface): the plain conversion,
    else typer's own (``fallback()``, built once on first use)."""

    def __init__(self, param: Any, fallback: Any) -> None:
        descriptor = param.type_descriptor
        self._info = descriptor.parameter_info
        self._annotation = descriptor.annotation
        self._item = None
        if getattr(self._annotation, "__origin__", None) is list:
            (self._item,) = self._annotation.__args__
        self._fallback = fallback
        self._converter: Any = None

    def coerce(self, value: Any, param: Any, ctx: Any) -> Any:
        several = param.multiple or param.nargs == -1
        if value is None:  # as typer's converter has it, without building it
            return () if several else None
        try:
            if self._item is None:
                if several or param.nargs != 1:
                    raise _Unconverted
                return _leaf(self._annotation, self._info, value, param, ctx)
            if not several or not isinstance(value, (list, tuple)):
                raise _Unconverted
            return [_leaf(self._item, self._info, item, param, ctx) for item in value]
        except _Unconverted:
            return self._typer().coerce(value, param=param, ctx=ctx)

    def _typer(self) -> Any:
        if self._converter is None:
            self._converter = self._fallback()
        return self._converter


def plain_values(params: list[Any]) -> None:
    """Give each typer parameter of ``params`` (a command's, ``Command.get_params``) the
    plain converter (see the module's docstring). Parameters converted already, and any where
    this typer has no such internals, are left as they are; all of them where this typer is
    not one it is tested with (:func:`engaged`)."""
    if not engaged():
        return
    for param in params:
        descriptor = getattr(param, "type_descriptor", None)
        if descriptor is None or getattr(param, "_runtime_param", False) is not None:
            continue
        if not callable(getattr(param, "get_runtime_param", None)):
            continue
        param._runtime_param = _PlainConverter(param, _typer_converter(descriptor))


def _typer_converter(descriptor: Any) -> Any:
    def build() -> Any:
        from typer._coercion import build_runtime_param

        return build_runtime_param(descriptor)

    return build


__all__ = ["TESTED_TYPER", "engaged", "plain_values"]
