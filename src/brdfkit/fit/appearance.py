r"""How alike two BRDFs look: CIEDE2000 colour differences between rendered spheres.

A fit can lower a numerical error and still look wrong (a lost highlight, a washed-out colour);
what a user judges is the picture. :func:`sphere_difference` renders both BRDFs on the same
sphere under the same light, exposes both alike — the brightest channel of the reference
sphere's median pixel to :data:`BODY_LEVEL`, so that body colours stay unclipped while
highlights clip to the display's [0, 1] as a screen would show them — and measures per pixel
the CIEDE2000 difference :math:`\Delta E_{00}` of their CIELAB colours (linear sRGB → XYZ →
L*a*b*, D65 white). About 1 is the threshold of a visible difference; a mean over the sphere below
~12 reads as "alike at a glance", beyond ~20 as "another material".

References
----------
.. [1] G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula: implementation
       notes, supplementary test data, and mathematical observations", Color Res. Appl. 30(1),
       2005.
.. [2] CIE 015:2018, *Colorimetry* (CIELAB); IEC 61966-2-1:1999 (sRGB).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.data import colorimetry
from brdfkit.light.analytic import DirectionalLight
from brdfkit.light.base import Light

BODY_LEVEL = 0.5
"""Linear value that the brightest channel of the reference sphere's median pixel is exposed to
(a luminance-based exposure would clip a saturated blue body colour and wash it out)."""

DEFAULT_LIGHT_DIRECTION = (-0.4, 0.5, 0.77)
"""The default directional light: from the upper left, in front of the default camera."""


@dataclass(frozen=True)
class SphereDifference:
    """Per-pixel :math:`\\Delta E_{00}` statistics over the sphere, and the exposed images.

    Attributes
    ----------
    mean, median, p95 : of :math:`\\Delta E_{00}` over the covered pixels.
    reference, other : the two renders, exposed alike and clipped to [0, 1] (linear sRGB).
    delta_e : per-pixel :math:`\\Delta E_{00}` (0 outside the sphere).
    """

    mean: float
    median: float
    p95: float
    reference: np.ndarray
    other: np.ndarray
    delta_e: np.ndarray

    def to_dict(self) -> dict[str, float]:
        """The statistics, for JSON."""
        return {"mean": self.mean, "median": self.median, "p95": self.p95}


def delta_e_2000(rgb_a: np.ndarray, rgb_b: np.ndarray) -> np.ndarray:
    """CIEDE2000 difference between linear-sRGB colours (``(..., 3)`` each, white = 1).

    Linear sRGB → XYZ (IEC 61966-2-1's matrix) → CIELAB (D65 white) →
    :func:`brdfkit.data.colorimetry.ciede2000` (Sharma, Wu & Dalal 2005; the formula is there).
    These are colour-science's ``RGB_to_XYZ``, ``XYZ_to_Lab`` and ``delta_E(method="CIE 2000")``,
    restated in :mod:`brdfkit.data.colorimetry` (the tests hold them equal to ~1e-12) rather
    than imported: colour-science is a 94 MiB install for one formula.

    References
    ----------
    .. [1] G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula:
           implementation notes, supplementary test data, and mathematical observations",
           Color Res. Appl. 30(1), 2005.

    Examples
    --------
    >>> import numpy as np
    >>> float(delta_e_2000(np.array([0.5, 0.2, 0.1]), np.array([0.5, 0.2, 0.1])))
    0.0
    >>> float(delta_e_2000(np.array([0.5, 0.2, 0.1]), np.array([0.5, 0.25, 0.1])).round(2))
    7.11
    """

    def lab(rgb: np.ndarray) -> np.ndarray:
        xyz = np.asarray(rgb, dtype=np.float64) @ colorimetry.LINEAR_SRGB_TO_XYZ.T
        return colorimetry.xyz_to_lab(xyz)

    return colorimetry.ciede2000(lab(rgb_a), lab(rgb_b))


def sphere_difference(
    reference: BRDF,
    other: BRDF,
    lights: Light | Sequence[Light] | None = None,
    resolution: int = 64,
    **shade_kwargs: object,
) -> SphereDifference:
    """:math:`\\Delta E_{00}` between spheres rendered with ``reference`` and ``other``.

    Parameters
    ----------
    reference, other : the BRDFs (e.g. a measured one and its fit).
    lights : default a directional light from :data:`DEFAULT_LIGHT_DIRECTION` with irradiance π.
    resolution : pixels across the sphere.
    shade_kwargs : passed to :func:`brdfkit.render.render_sphere` (e.g. ``samples``).

    Raises
    ------
    ValueError
        If the reference sphere renders black (nothing to expose by), or the BRDFs do not give
        three colour channels.

    Examples
    --------
    An orange and a blue Lambertian sphere look like different materials:

    >>> from brdfkit.brdf import Lambertian
    >>> orange, blue = Lambertian(rho=[0.5, 0.3, 0.2]), Lambertian(rho=[0.3, 0.3, 0.5])
    >>> sphere_difference(orange, orange, resolution=16).mean
    0.0
    >>> difference = sphere_difference(orange, blue, resolution=16)
    >>> difference.mean > 20, difference.delta_e.shape
    (True, (16, 16))
    """
    from brdfkit.render.shading import render_sphere

    if lights is None:
        lights = [DirectionalLight(direction=DEFAULT_LIGHT_DIRECTION, irradiance=np.pi)]
    a = render_sphere(reference, lights, resolution, **shade_kwargs)
    b = render_sphere(other, lights, resolution, **shade_kwargs)
    if a.shape[-1] != 3 or b.shape[-1] != 3:
        raise ValueError(
            f"reference and other must give RGB (3 channels); got {a.shape[-1]} and {b.shape[-1]}"
        )
    mask = np.any(a > 0, axis=-1) | np.any(b > 0, axis=-1)
    median = float(np.median(np.max(a[mask], axis=-1))) if mask.any() else 0.0
    if not median > 0:
        raise ValueError(
            f"reference renders black (median brightest channel {median}); cannot expose it"
        )
    exposure = BODY_LEVEL / median
    a, b = np.clip(a * exposure, 0, 1), np.clip(b * exposure, 0, 1)
    delta_e = np.zeros(mask.shape)
    delta_e[mask] = delta_e_2000(a[mask], b[mask])
    values = delta_e[mask]
    return SphereDifference(
        mean=float(values.mean()),
        median=float(np.median(values)),
        p95=float(np.percentile(values, 95)),
        reference=a,
        other=b,
        delta_e=delta_e,
    )


__all__ = [
    "BODY_LEVEL",
    "DEFAULT_LIGHT_DIRECTION",
    "SphereDifference",
    "delta_e_2000",
    "sphere_difference",
]
