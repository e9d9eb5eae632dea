"""Error measures for estimated normals and depths.

The angular error is computed as the DiLiGenT benchmark does it: for unit normals ``n`` and
``n_gt``, ``angle = degrees(arccos(clip(n . n_gt, -1, 1)))`` at every mask pixel, summarised by
its mean and median over the mask.

References
----------
.. [1] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._array import dot, normalize
from brdfkit._checks import as_float_array
from brdfkit.errors import ParameterError


def _check_mask(mask: ArrayLike | None, shape: tuple[int, ...]) -> np.ndarray:
    """A boolean mask of ``shape`` with at least one pixel (all pixels when ``None``)."""
    if mask is None:
        return np.ones(shape, dtype=bool)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != shape:
        raise ParameterError(f"mask must have shape {shape}, got shape {mask.shape}")
    if not mask.any():
        raise ParameterError("mask has no pixels set: the error is undefined")
    return mask


def angular_error_map(
    normals: ArrayLike, normals_gt: ArrayLike, mask: ArrayLike | None = None
) -> np.ndarray:
    """Per-pixel angle between two normal maps, in degrees; NaN outside ``mask``.

    ``angle = degrees(arccos(clip(n . n_gt, -1, 1)))``; both maps are normalised to unit length
    first (a no-op for unit normals), a zero normal counting as 90° off.

    Parameters
    ----------
    normals, normals_gt : (H, W, 3) normal maps in the same frame.
    mask : (H, W) bool; all pixels when omitted.

    References
    ----------
    B. Shi et al., IEEE TPAMI 41(2), 2019 (the DiLiGenT evaluation code).

    Examples
    --------
    >>> import numpy as np
    >>> up = np.broadcast_to([0.0, 0.0, 1.0], (1, 2, 3))
    >>> tilted = np.array([[[0.0, 0.0, 1.0], [0.0, 0.5, 0.5]]])
    >>> angular_error_map(tilted, up).round(6).tolist()
    [[0.0, 45.0]]
    """
    normals = as_float_array("normals", normals, finite=False)
    normals_gt = as_float_array("normals_gt", normals_gt, finite=False)
    if normals.shape != normals_gt.shape or normals.ndim != 3 or normals.shape[2] != 3:
        raise ParameterError(
            f"normals and normals_gt must both have shape (H, W, 3), got {normals.shape} and "
            f"{normals_gt.shape}"
        )
    mask = _check_mask(mask, normals.shape[:2])
    for name, value in (("normals", normals), ("normals_gt", normals_gt)):
        if not np.all(np.isfinite(value[mask])):
            raise ParameterError(f"{name} must be finite inside the mask")
    cosine = np.clip(dot(normalize(normals), normalize(normals_gt)), -1.0, 1.0)
    return np.where(mask, np.degrees(np.arccos(cosine)), np.nan)


def angular_error(
    normals: ArrayLike, normals_gt: ArrayLike, mask: ArrayLike | None = None
) -> dict[str, float]:
    """Mean and median angular error in degrees over ``mask`` (the DiLiGenT numbers).

    Returns
    -------
    ``{"mean": ..., "median": ...}`` of :func:`angular_error_map` over the mask.

    References
    ----------
    B. Shi et al., IEEE TPAMI 41(2), 2019.

    Examples
    --------
    >>> import numpy as np
    >>> up = np.broadcast_to([0.0, 0.0, 1.0], (1, 3, 3))
    >>> tilted = np.array([[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.5, 0.5]]])
    >>> {name: round(value, 6) for name, value in angular_error(tilted, up).items()}
    {'mean': 15.0, 'median': 0.0}
    """
    normals = np.asarray(normals)
    mask = _check_mask(mask, normals.shape[:2])
    values = angular_error_map(normals, normals_gt, mask)[mask]
    return {"mean": float(values.mean()), "median": float(np.median(values))}


def depth_error(
    depth: ArrayLike, depth_gt: ArrayLike, mask: ArrayLike | None = None
) -> dict[str, float]:
    """Depth error after the best scale and offset: ``min_{a, c} ||a z + c - z_gt||`` on the mask.

    Normal integration recovers depth up to an offset (orthographic) or a scale (perspective),
    so both are fitted by linear least squares over the mask before comparing.

    Returns
    -------
    ``{"rmse": ..., "relative_rmse": ..., "scale": a, "offset": c}`` with ``relative_rmse`` the
    RMSE divided by the range ``max - min`` of ``depth_gt`` over the mask.

    References
    ----------
    Y. Quéau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", J. Math. Imaging Vis. 60,
    576-593, 2018 (evaluation up to the integration constant).

    Examples
    --------
    A depth off by a constant has no error; the fitted offset says by how much:

    >>> import numpy as np
    >>> depth_gt = np.arange(6.0).reshape(2, 3)
    >>> {name: round(value, 6) for name, value in depth_error(depth_gt + 10, depth_gt).items()}
    {'rmse': 0.0, 'relative_rmse': 0.0, 'scale': 1.0, 'offset': -10.0}
    """
    depth = as_float_array("depth", depth, finite=False)
    depth_gt = as_float_array("depth_gt", depth_gt, finite=False)
    if depth.shape != depth_gt.shape or depth.ndim != 2:
        raise ParameterError(
            f"depth and depth_gt must both have shape (H, W), got {depth.shape} and "
            f"{depth_gt.shape}"
        )
    mask = _check_mask(mask, depth.shape)
    z, z_gt = depth[mask], depth_gt[mask]
    if not (np.all(np.isfinite(z)) and np.all(np.isfinite(z_gt))):
        raise ParameterError("depth and depth_gt must be finite inside the mask")
    design = np.stack([z, np.ones_like(z)], axis=1)
    (scale, offset), *_ = np.linalg.lstsq(design, z_gt, rcond=None)
    rmse = float(np.sqrt(np.mean((scale * z + offset - z_gt) ** 2)))
    span = float(z_gt.max() - z_gt.min())
    return {
        "rmse": rmse,
        "relative_rmse": rmse / span if span > 0 else float("nan"),
        "scale": float(scale),
        "offset": float(offset),
    }
