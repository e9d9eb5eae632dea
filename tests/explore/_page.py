"""Helpers that drive the explorer page in a test (waiting for frames, reading canvases)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from brdfkit.io import srgb_encode

WAIT_MS = 30_000


RESTED = (
    "const x = window.explorer; return x && x.sent && x.shown.seq === x.sent.seq"
    " && !x.moving && !x.shown.preview"
)
"""The page shows the full reply to the last state it sent: no slider is moving (a dragged
slider's previews are refined once it rests) and the frame shown is no preview."""


def settled(page: Any, after: int = 0) -> int:
    """Wait until the page shows the full reply to the last state it sent (and nothing is
    pending; :data:`RESTED`), with a sequence number above ``after``; returns it."""
    page.wait_for_function(
        f"([after]) => {{ {RESTED} && x.shown.seq > after; }}", arg=[after], timeout=WAIT_MS
    )
    page.wait_for_timeout(50)  # a coalesced change may follow the reply at once
    page.wait_for_function(f"() => {{ {RESTED}; }}", timeout=WAIT_MS)
    return page.evaluate("window.explorer.shown.seq")


def canvas_pixels(page: Any, selector: str) -> np.ndarray:
    """The RGBA pixels of a canvas, ``(H, W, 4)`` uint8."""
    data = page.evaluate(
        """(sel) => { const c = document.querySelector(sel);
           const d = c.getContext('2d').getImageData(0, 0, c.width, c.height);
           return [c.width, c.height, Array.from(d.data)]; }""",
        selector,
    )
    width, height, values = data
    return np.asarray(values, np.uint8).reshape(height, width, 4)


def expected_pixels(linear: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """What the page must show for a linear image under sRGB display: 8-bit RGB."""
    if linear.shape[-1] == 1:
        linear = np.repeat(linear, 3, axis=-1)
    encoded = srgb_encode(np.clip(linear * 2.0**exposure, 0.0, 1.0))
    return np.round(encoded * 255).astype(np.int64)


def light_world(theta_i_deg: float, phi_i_deg: float) -> np.ndarray:
    """The sphere's light in the render's world for local (θi, φi): local z is the world's +x
    (towards the camera), local x the image's right (+y), local y its top (+z)."""
    t, p = math.radians(theta_i_deg), math.radians(phi_i_deg)
    return np.array([math.cos(t), math.sin(t) * math.cos(p), math.sin(t) * math.sin(p)])
