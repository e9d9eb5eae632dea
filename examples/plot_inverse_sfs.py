"""
Shape from shading on a real photograph
=======================================

One image and a known distant light: :func:`~brdfkit.vision.shape_from_shading.shape_from_shading`
minimises Horn's variational energy (brightness error plus smoothness; Horn & Brooks 1986,
Horn 1989) over the depth itself, so the recovered gradients are integrable by construction,
by Gauss–Newton with the exact sparse Jacobian, from a convex tent inside the mask. The input
is the matte gray sphere of the psm photometric-stereo course set
(:func:`~brdfkit.vision.datasets.load_psm`), the image whose light (from ``lights.txt``, itself
a few degrees off) is nearest the view, averaged over 6×6 blocks: the cost grows quickly with
the image's size. The ground truth is the normals of the circle fitted to the mask; the error
map is :func:`~brdfkit.vision.metrics.angular_error_map`.

Without the shared data folder the example renders a Lambertian sphere instead.

This is the README's picture ``docs/images/inverse_sfs.png``: running this file as a script
writes it (from the real photograph only).
"""

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from brdfkit.io import data_path
from brdfkit.vision.datasets import load_psm
from brdfkit.vision.metrics import angular_error, angular_error_map
from brdfkit.vision.photometric_stereo import sphere_normals
from brdfkit.vision.shape_from_shading import shape_from_shading

STEP = 6
try:
    data = load_psm(data_path("photometric_stereo", "psm", "gray"))
except FileNotFoundError as missing:
    print(f"{missing}: rendering a Lambertian sphere instead")
    data = None

if data is not None:
    name = "psm gray (input)"
    k = int(np.argmax(data.light_directions[:, 2]))  # the light nearest the view direction
    light = data.light_directions[k]
    h, w = (s // STEP * STEP for s in data.mask.shape)

    def blocks(a):
        return a[:h, :w].reshape(h // STEP, STEP, w // STEP, STEP, *a.shape[2:])

    image = blocks(data.images[k].mean(axis=-1)).mean(axis=(1, 3))
    mask = blocks(data.mask).all(axis=(1, 3))
    truth = blocks(data.normals).mean(axis=(1, 3))
    truth /= np.maximum(np.linalg.norm(truth, axis=-1, keepdims=True), 1e-12)
    # Crop to the sphere (and a margin) for the picture; the solver sees only the mask anyway.
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    crop = np.s_[max(rows[0] - 2, 0) : rows[-1] + 3, max(cols[0] - 2, 0) : cols[-1] + 3]
    image, mask, truth = image[crop], mask[crop], truth[crop]
else:
    name = "rendered sphere (input)"
    light = np.array([0.1, 0.05, 0.99]) / np.linalg.norm([0.1, 0.05, 0.99])
    truth, mask = sphere_normals((56, 56), (27.5, 27.5), 24.0)
    image = np.clip(truth @ light, 0, None) * mask

# %%
# The solver; its normals are compared with the truth inside the mask.
result = shape_from_shading(image, light, mask)
errors = angular_error(result.normals, truth, mask)
print(f"mean {errors['mean']:.1f}°, median {errors['median']:.1f}° over {mask.sum()} pixels")

# %%
# Depth and normals are shown inside the mask; normals as RGB = (n + 1) / 2.
fig = Figure(figsize=(6.75, 1.9), layout="constrained")
axes = fig.subplots(1, 4)
axes[0].imshow(image, cmap="gray", vmin=0)
axes[1].imshow(np.where(mask, result.depth, np.nan), cmap="viridis")
axes[2].imshow(np.where(mask[..., None], (result.normals + 1) / 2, 0))
im = axes[3].imshow(
    np.where(mask, angular_error_map(result.normals, truth, mask), np.nan),
    cmap="magma",
    vmin=0,
    vmax=20,
)
titles = [
    name,
    "recovered depth",
    "recovered normals",
    f"angular error (mean {errors['mean']:.1f}°)",
]
for ax, title in zip(axes, titles, strict=True):
    ax.set_title(title, fontsize="x-small")
    ax.axis("off")
fig.colorbar(im, ax=axes[3], shrink=0.9)

# %%
# Running the file as a script writes the README's picture (from the real photograph only).
if "BRDFKIT_DOCS_BUILD" not in os.environ and data is not None:
    fig.savefig(Path(__file__).resolve().parents[1] / "docs/images/inverse_sfs.png", dpi=100)
