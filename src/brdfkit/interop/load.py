"""One loader for every source of a BRDF: spec strings, measured files, fits and shaders.

:func:`load` is what every command that takes a model calls, so that a spec
(``"ggx(alpha=0.2)"``), a measured file (MERL ``.binary``, RGL ``.bsdf``, Cornell ``.brdf``),
the ``fit.json`` that ``brdfkit fit`` writes and a Disney BRDF Explorer ``.brdf`` shader are
interchangeable wherever a BRDF is wanted.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

from brdfkit.brdf.base import BRDF, Scaled, Sum
from brdfkit.errors import FormatError, ParameterError, SpecError

__all__ = ["FILE_SUFFIXES", "MAX_FIT_BYTES", "is_file_source", "load"]

FILE_SUFFIXES = (".binary", ".bsdf", ".brdf", ".json")
"""The file extensions :func:`load` reads: MERL, RGL, Cornell or BRDF Explorer, fit.json."""

MAX_FIT_BYTES = 1 << 20
"""The largest ``fit.json`` :func:`load` reads (one holds a few kilobytes)."""


def is_file_source(source: str | os.PathLike) -> bool:
    """Whether :func:`load` reads ``source`` as a file (a path object, or a string ending in
    one of :data:`FILE_SUFFIXES`) rather than as a spec string."""
    if not isinstance(source, str):
        return True
    return Path(source).suffix.lower() in FILE_SUFFIXES


def load(source: str | os.PathLike | BRDF, **params: Any) -> BRDF:
    """The BRDF that ``source`` describes, with the parameters ``params`` set.

    ``source`` is one of:

    - a spec string, read by :func:`brdfkit.brdf.parse` (``"lambertian(albedo=0.5)"``);
    - a measured file: MERL ``.binary``, RGL ``.bsdf`` or Cornell ``.brdf``
      (:mod:`brdfkit.measured`);
    - a ``fit.json`` written by ``brdfkit fit``: its fitted ``"spec"``;
    - a Disney BRDF Explorer ``.brdf`` file (first line ``analytic``):
      :func:`~brdfkit.interop.brdf_explorer.read_brdf_explorer`;
    - a BRDF, returned as it is (or with ``params`` set).

    ``params`` set the parameters of a single model (a spec or fit of one model, or a BRDF
    Explorer shader's parameters); a sum or product of models and measured data take none.

    Raises
    ------
    brdfkit.errors.SpecError
        For a spec outside the grammar, or a parameter name the model does not have.
    brdfkit.errors.FormatError
        For a file its reader refuses (naming the file and what is wrong).
    brdfkit.errors.ParameterError
        For a parameter value outside its domain, or parameters given to measured data.
    OSError
        For a file that cannot be read.

    Examples
    --------
    >>> load("lambertian(albedo=0.5)").rho
    0.5
    >>> load("ggx(alpha=0.2)", alpha=0.4).alpha
    0.4
    >>> load("lambertian + ggx", alpha=0.4)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.SpecError: parameters (alpha) set a single model; ... write them in the spec
    """
    if isinstance(source, BRDF):
        return _with_params(source, params, "the model")
    if not is_file_source(source):
        from brdfkit.brdf import parse

        return _with_params(parse(source), params, repr(source))
    path = os.fspath(source)
    if not Path(path).is_file():
        raise FileNotFoundError(f"BRDF file not found: {path}")
    suffix = Path(path).suffix.lower()
    # the shader reader (with the GLSL interpreter and brdfkit.measured) only for its files
    from brdfkit.interop.brdf_explorer import is_brdf_explorer_file, read_brdf_explorer

    if suffix == ".brdf" and is_brdf_explorer_file(path):
        return read_brdf_explorer(path, **params)
    if suffix == ".json":
        return _with_params(_read_fit(path), params, path)
    from brdfkit import measured

    if params:
        names = ", ".join(sorted(params))
        raise ParameterError(f"{path} is measured data and takes no parameters; got {names}")
    return measured.read(path)


def _read_fit(path: str) -> BRDF:
    """The fitted model of the ``fit.json`` at ``path``."""
    from brdfkit.brdf import parse

    if os.path.getsize(path) > MAX_FIT_BYTES:
        raise FormatError(path, f"holds over {MAX_FIT_BYTES} bytes; a fit.json holds a few KB")
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except (ValueError, RecursionError):
        raise FormatError(path, "is not JSON (a fit.json written by brdfkit fit)") from None
    if not isinstance(record, dict) or not isinstance(record.get("spec"), str):
        raise FormatError(path, 'has no "spec" string (a fit.json written by brdfkit fit)')
    return parse(record["spec"])


def _with_params(model: BRDF, params: dict[str, Any], source: str) -> BRDF:
    """``model`` with ``params`` set (spec aliases accepted), validated by its constructor."""
    if not params:
        return model
    from brdfkit.interop.brdf_explorer import ExplorerBRDF

    names = ", ".join(sorted(params))
    if isinstance(model, ExplorerBRDF):
        return model.with_values(**params)
    if isinstance(model, Sum | Scaled) or not dataclasses.is_dataclass(model):
        raise SpecError(
            f"parameters ({names}) set a single model; {source} is {model.to_spec()!r}: "
            "write them in the spec"
        )
    aliases = type(model).spec_aliases
    fields = {f.name for f in dataclasses.fields(model)}
    renamed = {aliases.get(name, name): value for name, value in params.items()}
    unknown = sorted(set(renamed) - fields)
    if unknown:
        raise SpecError(
            f"{model.spec_name} has no parameter {unknown[0]!r}; "
            f"its parameters: {', '.join(sorted(fields))}"
        )
    return dataclasses.replace(model, **renamed)
