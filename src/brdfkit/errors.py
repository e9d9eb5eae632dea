"""The exception types brdfkit raises for bad input.

Every reader, validator and command raises one of these for input it cannot use, and nothing
else: anything outside this family escaping a public function on bad input is a bug. Each is
also a built-in type (``ValueError`` or ``OSError``), so ``except ValueError`` keeps working.

==========================  ========================================================================
type                        raised when
==========================  ========================================================================
:class:`FormatError`        a file is not what its reader expects (truncated, corrupt, NaN inside,
                            …); the message names the file and, where known, the field or byte
                            offset
:class:`ParameterError`     a parameter or argument is not finite or lies outside its domain; the
                            message names it, its value and the domain
:class:`SpecError`          a model or light spec string is outside the grammar or names an unknown
                            model or parameter
:class:`ResourceError`      a requested size would need more memory than the machine has, or exceeds
                            the documented maximum of an option
:class:`OutputError`        an output path cannot be used: it is an input, lies inside one, is an
                            existing file where a folder is wanted, or cannot be written
:class:`MissingExtraError`  a package of an optional part is not installed; the message names the
                            extra that installs it (``pip install 'brdfkit[explore]'``)
==========================  ========================================================================

The command line prints such an error as one line on standard error and exits with status 2.
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

__all__ = [
    "EXTRAS",
    "BrdfkitError",
    "FormatError",
    "MissingExtraError",
    "OutputError",
    "ParameterError",
    "ResourceError",
    "SpecError",
    "missing_extra",
    "require_extra",
]


class BrdfkitError(Exception):
    """Base of every error brdfkit raises for bad input."""


class FormatError(BrdfkitError, ValueError):
    """A file's contents are not in the format its reader expects.

    Parameters
    ----------
    path : str or path-like
        The file.
    reason : str
        What is wrong, in words a user can act on.
    field : str, optional
        The header field, key or section where the problem lies.
    offset : int, optional
        The byte offset (binary formats) or line number (text formats, with ``line=True``).
    line : bool
        ``offset`` counts lines (1-based) rather than bytes.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        reason: str,
        *,
        field: str | None = None,
        offset: int | None = None,
        line: bool = False,
    ) -> None:
        self.path = os.fspath(path)
        self.reason = reason
        self.field = field
        self.offset = offset
        where = []
        if field is not None:
            where.append(f"field {field!r}")
        if offset is not None:
            where.append(f"line {offset}" if line else f"byte {offset}")
        located = f" ({', '.join(where)})" if where else ""
        super().__init__(f"{self.path}{located}: {reason}")


class ParameterError(BrdfkitError, ValueError):
    """A parameter or argument is not finite or outside its domain."""


class SpecError(BrdfkitError, ValueError):
    """A spec string (a model or light) cannot be read."""


class ResourceError(BrdfkitError, ValueError):
    """A requested size exceeds an option's maximum or the memory available."""


class OutputError(BrdfkitError, OSError):
    """An output path cannot be used (it is an input, an existing file, or not writable)."""


EXTRAS = {
    "starlette": "explore",
    "uvicorn": "explore",
    "websockets": "explore",
    "anywidget": "explore",
    "dask": "dask",
    "distributed": "dask",
    "zarr": "dask",
    "torch": "torch",
    "jax": "jax",
    "numba": "accel",
    "sphinx": "docs",
    "mitsuba": "oracle",
    "drjit": "oracle",
    "moderngl": "glsl-oracle",
    "embreex": "mesh",
    "pygltflib": "gltf",
    "MaterialX": "materialx",
    "pxr": "usd",
}
"""The extra of ``pyproject.toml`` that installs each optional package, by its import name."""


class MissingExtraError(BrdfkitError, ImportError):
    """A package of an optional part of brdfkit is not installed.

    Parameters
    ----------
    module : str
        The import name of the missing package (``"starlette"``).
    extra : str
        The extra that installs it (``"explore"``).
    needed_by : str
        What needs it, the subject of the message (the command line names the command).
    """

    def __init__(self, module: str, extra: str, needed_by: str = "this") -> None:
        self.module = module
        self.extra = extra
        super().__init__(
            f"{needed_by} needs the {extra!r} extra ({module} is not installed): "
            f"pip install 'brdfkit[{extra}]'",
            name=module,
        )


def require_extra(module: str, extra: str | None = None) -> ModuleType:
    """Import ``module`` of an optional part, or raise :class:`MissingExtraError` naming the
    extra that installs it (``extra``, by default :data:`EXTRAS` of its top-level package).

    Examples
    --------
    >>> require_extra("json").__name__
    'json'
    >>> require_extra("no_such_package", "explore")
    Traceback (most recent call last):
    ...
    brdfkit.errors.MissingExtraError: this needs the 'explore' extra (no_such_package is not \
installed): pip install 'brdfkit[explore]'
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        missing = (error.name or module).split(".")[0]
        wanted = extra or EXTRAS.get(module.split(".")[0]) or EXTRAS.get(missing)
        if wanted is None:
            raise
        raise MissingExtraError(missing, wanted) from None


def missing_extra(error: ModuleNotFoundError) -> MissingExtraError | None:
    """The :class:`MissingExtraError` that a ``ModuleNotFoundError`` for a package of
    :data:`EXTRAS` means, or ``None`` for any other module (a broken installation)."""
    missing = (error.name or "").split(".")[0]
    return MissingExtraError(missing, EXTRAS[missing]) if missing in EXTRAS else None
