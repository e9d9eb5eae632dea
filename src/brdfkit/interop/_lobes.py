"""What every exporter needs of a model: its lobes with their scales, and parameters as
one number or an RGB triple."""

from __future__ import annotations

from typing import Any

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf import BRDF, Scaled, Sum
from brdfkit.errors import ParameterError


def values(model: BRDF, name: str, value: Any, tool: str) -> np.ndarray:
    """A parameter as 1 or 3 floats; spatially varying or spectral values are refused,
    naming ``tool`` (the format being written)."""
    array = np.asarray(to_numpy(value), dtype=np.float64)
    if array.ndim > 1 or array.size not in (1, 3):
        raise ParameterError(
            f"{type(model).__name__} {name} of shape {array.shape} has no {tool} counterpart "
            "here: export one number or an RGB triple per parameter"
        )
    return array.reshape(-1)


def flattened(brdf: BRDF, scale: np.ndarray, tool: str) -> list[tuple[BRDF, np.ndarray]]:
    """The lobes of nested sums and products, each with the product of its scales."""
    if isinstance(brdf, Scaled):
        return flattened(brdf.inner, scale * values(brdf, "k", brdf.k, tool), tool)
    if isinstance(brdf, Sum):
        return [pair for lobe in brdf.lobes for pair in flattened(lobe, scale, tool)]
    return [(brdf, scale)]


__all__ = ["flattened", "values"]
