"""brdfkit: the physics of appearance, computable.

Radiometry, BRDFs (analytic and measured) and their physics, light, the reflection equation,
rendering, and the inverse problems of physics-based vision, vectorised over NumPy, PyTorch and
JAX arrays. See ``DESIGN.md`` for the conventions: local frame with z the normal, ``wi`` towards
the light, ``wo`` towards the viewer, directions ``(..., 3)`` in and values ``(..., C)`` out, SI
units.
"""

from importlib import import_module
from typing import Any

__all__ = ["__version__", "load"]


def __getattr__(name: str) -> Any:
    """``brdfkit.load`` (:func:`brdfkit.interop.load.load`) and ``brdfkit.__version__`` (from
    the installed metadata), looked up on first use (PEP 562) so that ``import brdfkit`` stays
    cheap: ``importlib.metadata`` alone takes tens of ms; the root package is no layer of its
    own."""
    if name == "load":
        return import_module("brdfkit.interop.load").load
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("brdfkit")
        except PackageNotFoundError:  # running from a source tree that is not installed
            return "0.0.0+unknown"
    raise AttributeError(f"module 'brdfkit' has no attribute {name!r}")
