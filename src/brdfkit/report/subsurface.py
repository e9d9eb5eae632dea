"""The atlas's subsurface-scattering section: a BRDF sphere beside a BSSRDF sphere.

The lectures close the BRDF's family with the BSSRDF — light "arriving at a point" leaves
elsewhere — and show it as a BRDF and a BSSRDF rendering side by side: subsurface scattering
makes surfaces look softer. :func:`subsurface_spheres_row` renders that pair with
:func:`brdfkit.bssrdf.subsurface_spheres` (a Lambertian sphere and Christensen–Burley's
normalized diffusion of the same skin-like diffuse colour, red light travelling farthest, under
one directional light) for the last section of the atlas page.

References
----------
.. [1] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A practical model for subsurface
       light transport", SIGGRAPH 2001.
.. [2] P. H. Christensen, B. Burley, "Approximate reflectance profiles for efficient subsurface
       scattering", Pixar Technical Memo 15-04, 2015.
"""

from __future__ import annotations

import numpy as np

from brdfkit.bssrdf import Medium, NormalizedDiffusion, subsurface_spheres
from brdfkit.plot import encode_spheres

TITLE = "Beyond the BRDF: subsurface scattering"
"""The section's heading (and its anchor in the atlas's table of contents)."""

COLOUR = (0.85, 0.55, 0.40)
"""The diffuse colour both spheres share (skin-like)."""

SIGMA_T = (10.0, 20.0, 40.0)
"""The medium's extinction per sphere radius in red, green and blue: red travels farthest."""

LIGHT = (0.2, 1.0, 0.5)
"""The direction towards the light (world; the camera on +x, z up)."""


def subsurface_spheres_row(resolution: int = 64, samples: int = 16) -> np.ndarray:
    """The two spheres side by side, 8-bit sRGB ``(resolution, 2·resolution + 4, 3)``.

    Examples
    --------
    >>> row = subsurface_spheres_row(resolution=16, samples=4)
    >>> row.shape, row.dtype.name
    ((16, 36, 3), 'uint8')
    """
    medium = Medium(0.9, sigma_t=np.asarray(SIGMA_T), eta=1.4)
    model = NormalizedDiffusion(medium, surface_albedo=COLOUR)
    brdf, bssrdf = subsurface_spheres(model, light=LIGHT, resolution=resolution, samples=samples)
    gap = np.zeros((resolution, 4, 3), np.uint8)
    left, right = encode_spheres([np.pi * brdf, np.pi * bssrdf])
    return np.concatenate([left, gap, right], axis=1)


CAPTION = "BRDF (Lambertian) · BSSRDF (normalized diffusion), the same diffuse colour"
"""The row's caption."""

SUMMARY = (
    "A BRDF sends light out where it arrived; a BSSRDF lets it enter, scatter under the surface "
    "and leave elsewhere, so the surface looks softer: where the light is uniform the two "
    "spheres agree, at the terminator the translucent one bleeds light into the shadow, reddest "
    f"where it travelled farthest. Left: Lambertian, diffuse colour {COLOUR}; right: "
    "NormalizedDiffusion of the same colour, mean free paths "
    f"{', '.join(f'{1 / s:g}' for s in SIGMA_T)} sphere radii (red, green, blue). See "
    "brdfkit.bssrdf: a random-walk reference, four diffusion models and their errors."
)
"""The section's text (plain; the atlas escapes it)."""


__all__ = ["CAPTION", "COLOUR", "LIGHT", "SIGMA_T", "SUMMARY", "TITLE", "subsurface_spheres_row"]
