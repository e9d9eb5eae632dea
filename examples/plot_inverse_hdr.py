"""
Radiometric calibration: a camera's response and an HDR merge
=============================================================

Six 8-bit exposures (1/64 to 16, in steps of four) are synthesised from a real Poly Haven HDR
map (Spruit sunrise, box-averaged to 128×256) through a known camera-like response, a gamma
with a soft shoulder. :func:`~brdfkit.vision.calibration.recover_response` solves Debevec &
Malik's (1997) gsolve system for g = ln f⁻¹ per channel (hat weights, smoothness λ = 50, 200
sampled pixels), and :func:`~brdfkit.vision.calibration.merge_hdr` averages the exposures into
radiance. OpenCV's ``CalibrateDebevec`` with the same settings is drawn for comparison. The
curves are only defined up to an additive constant (gsolve fixes g(128) = 0): each is shifted
to the true curve over the well-exposed codes 16–239 before it is drawn and measured.

Without the shared data folder the example uses the (smaller) Poly Haven map that ships with
brdfkit.

This is the README's picture ``docs/images/inverse_hdr.png``: running this file as a script
writes it (from the Spruit sunrise map only).
"""

import os
from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure

from brdfkit.data import default_envmap_path
from brdfkit.io import data_path, read_image, srgb_encode, tonemap
from brdfkit.vision.calibration import merge_hdr, recover_response

TIMES = 2.0 ** np.arange(-6, 5, 2)
CODES = np.arange(256)
WELL_EXPOSED = (CODES >= 16) & (CODES <= 239)


def response(x):
    """The camera's response: codes / 255 from exposure (a gamma with a soft shoulder)."""
    x = np.clip(x, 0.0, 1.0)
    return x**0.45 * 1.2 / (1 + 0.2 * x**0.45)


try:
    source, name = data_path("envmaps", "polyhaven", "spruit_sunrise_1k.hdr"), "spruit_sunrise"
except FileNotFoundError as missing:
    print(f"{missing}: using brdfkit's bundled map instead")
    source, name = default_envmap_path(), "bundled map"
hdr = read_image(source).astype(np.float64)
f = hdr.shape[0] // 128
radiance = hdr[: 128 * f, : 256 * f].reshape(128, f, 256, f, 3).mean(axis=(1, 3))
radiance /= np.median(radiance)
stack = np.stack([np.round(255 * response(radiance * t)).astype(np.uint8) for t in TIMES])

# %%
# The true g, brdfkit's and OpenCV's (BGR order in and out of OpenCV).
xs = np.linspace(0.0, 1.0, 400001)
truth = np.log(np.maximum(np.interp(CODES / 255, response(xs), xs), 1e-12))
g = recover_response(stack, TIMES, smoothness=50.0, samples=200)
merged = merge_hdr(stack, TIMES, g)
bgr = [np.ascontiguousarray(image[..., ::-1]) for image in stack]
calibrate = cv2.createCalibrateDebevec(samples=200, lambda_=50.0, random=False)
g_cv = np.log(np.maximum(calibrate.process(bgr, TIMES.astype(np.float32))[:, 0, ::-1], 1e-30))


def aligned(curve):
    """The curve shifted to the truth over the well-exposed codes (the gauge is free)."""
    return curve + np.mean(truth[WELL_EXPOSED] - curve[WELL_EXPOSED])


for label, curve in (("brdfkit", g), ("OpenCV", g_cv)):
    rms = max(np.sqrt(np.mean((aligned(curve[:, c]) - truth)[WELL_EXPOSED] ** 2)) for c in range(3))
    print(f"{label:8s} ln f⁻¹ within {rms:.3f} (RMS over codes 16–239, worst channel)")
scale = np.exp(np.median(np.log(radiance / merged)))
print(f"merged radiance: {100 * np.median(np.abs(merged * scale - radiance) / radiance):.2f} %")

# %%
# The green channel's curves, one exposure, and the merge (Reinhard's operator, sRGB).
fig = Figure(figsize=(6.75, 1.8), layout="constrained")
curves, exposure, result = fig.subplots(1, 3, width_ratios=[0.7, 1, 1])
curves.plot(CODES, truth, "k", lw=2.5, label="true")
curves.plot(CODES, aligned(g[:, 1]), "--", color="C1", label="brdfkit")
curves.plot(CODES, aligned(g_cv[:, 1]), ":", color="C0", lw=1.5, label="OpenCV")
curves.set_ylim(-8, 0.8)
curves.set_xlabel("code", fontsize="small")
curves.set_title("ln f⁻¹ (green)", fontsize="small")
curves.legend(fontsize="x-small")
curves.tick_params(labelsize="x-small")
exposure.imshow(stack[3])  # exposure time 1: the sky clips
exposure.set_title(f"1 of {len(TIMES)} exposures (8-bit)", fontsize="small")
result.imshow(srgb_encode(tonemap(merged * scale, method="reinhard")))
result.set_title("merged radiance (tone-mapped)", fontsize="small")
for ax in (exposure, result):
    ax.axis("off")

# %%
# Running the file as a script writes the README's picture (from the Spruit sunrise map only).
if "BRDFKIT_DOCS_BUILD" not in os.environ and name == "spruit_sunrise":
    fig.savefig(Path(__file__).resolve().parents[1] / "docs/images/inverse_hdr.png", dpi=100)
