r"""A BSDF as a one-sided render sees it: sampling only the hemisphere the lights are in.

The reflection equation as :mod:`brdfkit.render.reflection_equation` evaluates it is one-sided:
lights lie above the surface, so only :math:`\omega_i` with :math:`\cos\theta_i > 0` contribute,

.. math:: L_o(\omega_o) = \int_{H^2_+} L_i(\omega_i)\,f(\omega_i, \omega_o)\cos\theta_i\,
          d\omega_i .

A BSDF's own sampler (a dielectric's: reflect with probability F, else refract) sends a
fraction of its samples below the surface, where they contribute nothing: from outside a glass
surface 1 − F ≈ 96 % of them. :func:`one_sided_view` wraps each transmitting lobe in
:class:`OneSided`, whose ``sample`` and ``pdf`` are the lobe's ``sample_one_sided`` and
``pdf_one_sided``: the lobe into the upper hemisphere chosen with probability 1 (reflection
from outside, refraction from inside), its probability moved into the sample weight
:math:`f\cos\theta_i/p`. The estimator of the integral above is unchanged in expectation
(unbiased: the new density is positive wherever the integrand is) and no sample is wasted; for
a smooth dielectric it becomes exact (:math:`F(\theta_o)\,L_i(\omega_r)`). ``eval`` is the
lobe's on the upper hemisphere, 0 below.

References
----------
.. [1] E. Veach, PhD thesis, Stanford, 1997, §2.5 (importance sampling), §5.2.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §9.5
       (``BSDFSample`` restricted by ``BxDFReflTransFlags``: sampling reflection only).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any

from brdfkit._array import Array, namespace
from brdfkit.brdf.base import BRDF, Sample, Scaled, Sum


@dataclass(frozen=True, eq=False)
class OneSided(BRDF):
    """``inner`` restricted to the upper hemisphere of ``wi`` (module docstring): a view for
    integration, not a material (it has no spec)."""

    inner: Any = None

    def __post_init__(self) -> None:
        if not hasattr(self.inner, "sample_one_sided"):
            raise TypeError(
                f"inner must be a BSDF with sample_one_sided/pdf_one_sided; got {self.inner!r}"
            )
        object.__setattr__(self, "channels", self.inner.channels)

    @property
    def has_delta(self) -> bool:  # type: ignore[override]
        return self.inner.has_delta

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.inner.isotropic

    def eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        value = self.inner.eval(wi, wo)
        return xp.where(wi[..., 2:3] > 0, value, xp.zeros_like(value))

    def pdf(self, wi: Array, wo: Array) -> Array:
        return self.inner.pdf_one_sided(wi, wo)

    def sample(self, wo: Array, u: Array) -> Sample:
        return self.inner.sample_one_sided(wo, u)

    def sampling_weight(self, wo: Array) -> Array:
        return self.inner.sampling_weight(wo)

    def to_spec(self) -> str:
        raise ValueError("a one-sided view has no spec; use the model it wraps (inner)")

    def __repr__(self) -> str:
        return f"OneSided({self.inner!r})"


_VIEWS: weakref.WeakKeyDictionary[BRDF, BRDF] = weakref.WeakKeyDictionary()


def one_sided_view(brdf: BRDF) -> BRDF:
    """``brdf`` with every transmitting lobe (alone, in a sum, scaled) wrapped in
    :class:`OneSided`; ``brdf`` itself where none transmits. The same view object is returned
    for the same ``brdf`` (compiled kernels are cached per model object)."""
    if not brdf.transmits:
        return brdf
    view = _VIEWS.get(brdf)
    if view is None:
        if isinstance(brdf, Sum):
            view = Sum(tuple(one_sided_view(lobe) for lobe in brdf.lobes))
        elif isinstance(brdf, Scaled):
            view = Scaled(brdf.k, one_sided_view(brdf.inner))
        elif hasattr(brdf, "sample_one_sided"):
            view = OneSided(brdf)
        else:
            view = brdf
        _VIEWS[brdf] = view
    return view


__all__ = ["OneSided", "one_sided_view"]
