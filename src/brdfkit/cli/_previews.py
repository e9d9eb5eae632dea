"""The PNG previews of photometric-stereo outputs (shared by ``brdfkit ps`` and ``brdfkit
svbrdf``): the albedo exposed by its 99th percentile, the angular error 0-45° as black-white."""

from __future__ import annotations

from typing import Any

ERROR_RANGE_DEG = 45.0
"""The angular error shown as white."""


def albedo_preview(albedo: Any, mask: Any) -> Any:
    """The albedo divided by its 99th percentile over ``mask`` (1 when that is 0), in [0, 1]."""
    import numpy as np

    scale = np.percentile(albedo[mask], 99) or 1.0
    return (albedo / scale).clip(0, 1).astype(np.float32)


def error_preview(error_map: Any) -> Any:
    """The angular error map in degrees as grey levels: 0° black, :data:`ERROR_RANGE_DEG` and
    beyond white, NaN (off the mask) black."""
    import numpy as np

    return np.nan_to_num(error_map / ERROR_RANGE_DEG, nan=0.0).clip(0, 1).astype(np.float32)
