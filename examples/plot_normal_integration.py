"""
Normal integration across a depth step
======================================

The real DiLiGenT goblet (ground-truth normals and depth, perspective): its stem and foot meet
the cup only behind the cup's rim, a depth step. Masked least squares
(:func:`~brdfkit.vision.normal_integration.least_squares_integration`) integrates across the
step and bends the shapes on either side; bilateral normal integration
(:func:`~brdfkit.vision.bilateral_integration.bilateral_integration`, Cao et al. 2022) keeps the
step, but the normals do not say how far the foot is behind the cup, and the authors' method
leaves it where its iterations put it. ``brdfkit integrate``'s default takes the scale of each
piece that the weights part from least squares; a few known depths, as a depth sensor gives
them (here one pixel in 256, with 2 mm of noise: ``brdfkit integrate --prior``), set it.
Each map is the error ``|s z - z_gt|`` with ``s`` the median of ``z_gt / z``, as BiNI's
evaluation scores it (mean: MADE).

Without the shared data folder the example integrates a synthetic stand-in: two planes parted
by a step that changes along their border, seen in perspective.
"""

import matplotlib.pyplot as plt
import numpy as np

from brdfkit.io import data_path
from brdfkit.vision.bilateral_integration import PIECES, bilateral_integration
from brdfkit.vision.datasets import load_normal_integration
from brdfkit.vision.normal_integration import least_squares_integration


def two_planes(size: int = 128):
    """Normals (x right, y up, z to the camera), mask, depth and ``K`` of a fronto-parallel
    plane at 1,000 on the left and, behind it on the right, a plane tilted about the x axis:
    the step between them changes along their border."""
    focal = 150.0
    camera = np.array([[focal, 0, (size - 1) / 2], [0, focal, (size - 1) / 2], [0, 0, 1.0]])
    rows, columns = np.indices((size, size), dtype=float)
    rays = np.stack(
        [(columns - camera[0, 2]) / focal, (rows - camera[1, 2]) / focal, np.ones_like(rows)], -1
    )
    right = columns >= size // 2
    tilted = np.array([0.0, 0.6, -1.0]) / np.hypot(0.6, 1.0)  # OpenCV frame, facing the camera
    depth = np.where(right, -1200.0 / np.hypot(0.6, 1.0) / (rays @ tilted), 1000.0)
    opencv = np.where(right[..., None], tilted, np.array([0.0, 0.0, -1.0]))
    return opencv * np.array([1.0, -1.0, -1.0]), np.ones((size, size), bool), depth, camera


try:
    data = load_normal_integration(data_path("normal_integration", "diligent", "goblet"))
    normals, mask, truth, camera, name = data.normals, data.mask, data.depth, data.camera, "goblet"
except FileNotFoundError as missing:
    print(f"{missing}: integrating a synthetic stand-in instead")
    normals, mask, truth, camera = two_planes()
    name = "two planes"

rng = np.random.default_rng(0)
prior = np.full(truth.shape, np.nan)
prior[::16, ::16] = truth[::16, ::16] + rng.normal(0.0, 2.0, prior[::16, ::16].shape)
prior[~mask] = np.nan

depths = {
    "least squares": least_squares_integration(normals, mask, camera),
    "bilateral (the authors')": bilateral_integration(normals, mask, camera).depth,
    "bilateral, piece scales\n(brdfkit integrate)": bilateral_integration(
        normals, mask, camera, pieces=PIECES
    ).depth,
    f"with {int(np.isfinite(prior).sum())} known depths\n(--prior)": bilateral_integration(
        normals, mask, camera, depth_prior=prior, pieces=PIECES
    ).depth,
}

# %%
# The error of each, in the units of the true depth (mm for the goblet).
rows, columns = (np.flatnonzero(mask.any(axis=axis)) for axis in (1, 0))
crop = np.s_[rows[0] : rows[-1] + 1, columns[0] : columns[-1] + 1]  # the object's box
fig, axes = plt.subplots(1, len(depths), figsize=(11, 3.6), layout="constrained")
for ax, (label, depth) in zip(axes, depths.items(), strict=True):
    scale = np.nanmedian(truth[mask] / depth[mask])
    error = np.where(mask, np.abs(scale * depth - truth), np.nan)
    image = ax.imshow(error[crop], vmin=0, vmax=10, cmap="magma")
    ax.set_title(f"{label}\nMADE {np.nanmean(error[mask]):.2f}", fontsize="small")
    ax.axis("off")
    print(f"{name}, {label.splitlines()[0]:28s} MADE {np.nanmean(error[mask]):.3f}")
units = " (mm)" if name == "goblet" else ""
fig.colorbar(image, ax=axes[-1], shrink=0.8, label=f"|s z - z_gt|{units}")
