"""brdfkit: the physics of appearance, computable.

Radiometry, BRDFs (analytic and measured) and their physics, light, the reflection equation,
rendering, and the inverse problems of physics-based vision, vectorised over NumPy, PyTorch and
JAX arrays. See ``DESIGN.md`` for the conventions: local frame with z the normal, ``wi`` towards
the light, ``wo`` towards the viewer, directions ``(..., 3)`` in and values ``(..., C)`` out, SI
units.
"""

from importlib import import_module

__all__ = ["__version__", "load"]


def __getattr__(name: str) -> object:
    """``brdfkit.__version__`` (from the installed package's metadata) and ``brdfkit.load``
    (:func:`brdfkit.interop.load.load`), each read on first use (PEP 562), so that ``import
    brdfkit`` costs next to nothing: the ``brdfkit`` command's Ctrl-C handling follows it
    (:mod:`brdfkit.cli._entry`). The root package is no layer of its own."""
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            found = version("brdfkit")
        except PackageNotFoundError:  # running from a source tree that is not installed
            found = "0.0.0+unknown"
        globals()["__version__"] = found
        return found
    if name == "load":
        return import_module("brdfkit.interop.load").load
    raise AttributeError(f"module 'brdfkit' has no attribute {name!r}")
