r"""Microfacet normal sampling shared by the rough conductor and the rough dielectric:
visible normals from ωo (Heitz & d'Eon 2014) or :math:`D\cos\theta_h` (Walter et al. 2007).

Visible normals are drawn from the side of the surface that ωo lies on: ``wo`` is flipped
into the upper hemisphere first, so that a BSDF seen from below samples the same normals.

References
----------
.. [1] E. Heitz, E. d'Eon, "Importance sampling microfacet-based BSDFs using the distribution
       of visible normals", EGSR 2014.
.. [2] B. Walter et al., "Microfacet models for refraction through rough surfaces", EGSR 2007,
       §5.3.
"""

from __future__ import annotations

import numpy as np

from brdfkit._array import Array, namespace
from brdfkit.brdf.base import _broadcast_rows
from brdfkit.brdf.microfacet import MicrofacetDistribution


def _upper(wo: Array) -> Array:
    """``wo`` flipped into the upper hemisphere where it lies below. A NumPy ``wo`` broadcast
    along batch axes (one ωo for a check's or an albedo estimate's samples) is flipped once
    per direction and stays broadcast, so that what the distribution makes per direction
    (:func:`~brdfkit.brdf.base.per_direction`) is made once, not once per sample."""
    rows = _broadcast_rows(wo)
    if rows is not None:
        return np.broadcast_to(np.where(rows[..., 2:3] > 0, rows, -rows), wo.shape)
    xp = namespace(wo)
    return xp.where(wo[..., 2:3] > 0, wo, -wo)


def sample_normal(ndf: MicrofacetDistribution, visible: bool, wo: Array, u: Array) -> Array:
    """Microfacet normals ωh, ``(..., 3)``, from ``u[..., :2]``: visible from ``wo`` or D cos θh."""
    u2 = u[..., :2]
    return ndf.sample_visible(_upper(wo), u2) if visible else ndf.sample(u2)


def normal_pdf(ndf: MicrofacetDistribution, visible: bool, wo: Array, h: Array) -> Array:
    """Density of :func:`sample_normal` choosing ``h`` given ``wo``, per steradian of ωh."""
    return ndf.pdf_visible(_upper(wo), h) if visible else ndf.pdf(h)
