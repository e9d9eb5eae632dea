"""Reflectance models: one module per family, all following the protocol of :mod:`.base`.

Each model module registers its models with the spec parser and exports the names in its
``__all__``, which this package re-exports (``from brdfkit.brdf import Lambertian``).
Importing the package imports no model module: a module is imported the first time one of
its names is asked for here or a spec names one of its models, and all of them when
:data:`MODELS` is listed (:mod:`._index` says which module holds what).
"""

import importlib
from typing import Any

from brdfkit.brdf._index import MODULES
from brdfkit.brdf.base import BRDF, MODELS, Sample, Scaled, Sum
from brdfkit.brdf.spec import parse

_MODULE_OF = {name: module for module, names in MODULES.items() for name in names}

__all__ = ["BRDF", "MODELS", "Sample", "Scaled", "Sum", "parse", *_MODULE_OF]


def __getattr__(name: str) -> Any:
    """A model module's name, its module imported (once) on first use."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
