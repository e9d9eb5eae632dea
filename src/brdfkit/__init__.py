"""brdfkit: the physics of appearance, computable.

Radiometry, BRDFs (analytic and measured) and their physics, light, the reflection equation,
rendering, and the inverse problems of physics-based vision, vectorised over NumPy, PyTorch and
JAX arrays. See ``DESIGN.md`` for the conventions: local frame with z the normal, ``wi`` towards
the light, ``wo`` towards the viewer, directions ``(..., 3)`` in and values ``(..., C)`` out, SI
units.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("brdfkit")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
