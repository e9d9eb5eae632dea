"""Reflectance models: one module per family, all following the protocol of :mod:`.base`.

Importing this package imports every model module in it, which registers each model with the
spec parser and re-exports the names in each module's ``__all__`` here
(``from brdfkit.brdf import Lambertian``).
"""

import importlib
import pkgutil

from brdfkit.brdf.base import BRDF, MODELS, Sample, Scaled, Sum
from brdfkit.brdf.spec import parse

__all__ = ["BRDF", "MODELS", "Sample", "Scaled", "Sum", "parse"]

for _module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if _module.name.startswith("_") or _module.name in ("base", "spec"):
        continue
    _mod = importlib.import_module(f"{__name__}.{_module.name}")
    for _name in getattr(_mod, "__all__", ()):
        globals()[_name] = getattr(_mod, _name)
        __all__.append(_name)
