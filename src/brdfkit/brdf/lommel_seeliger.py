r"""The Lommel–Seeliger law: single scattering in a semi-infinite, sparse, dark medium."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from brdfkit._array import Array, constant, namespace, safe_div
from brdfkit.brdf.base import ALBEDO, BRDF, register
from brdfkit.brdf.phong import Component, MixtureSampled, cosine_component
from brdfkit.params import Domain, param


def lommel_seeliger_albedo(w: Array, mu: Array) -> Array:
    r"""Directional albedo of the Lommel–Seeliger law,
    :math:`\rho(\mu) = \frac{w}{2}\bigl[1 - \mu\ln\frac{1+\mu}{\mu}\bigr]`, at ``mu`` > 0.

    ``w`` ``(..., C)`` and ``mu`` ``(..., 1)`` broadcast; 0 where ``mu`` ≤ 0. It rises from
    :math:`w(1-\ln 2)/2 \approx 0.153\,w` at normal view to w/2 at grazing view, so the law
    conserves energy for w ≤ 1 (half the single-scattered light leaves downwards).
    """
    xp = namespace(w, mu)
    positive = mu > 0
    safe_mu = xp.where(positive, mu, xp.ones_like(mu))
    value = 0.5 * w * (1 - safe_mu * (xp.log1p(safe_mu) - xp.log(safe_mu)))
    return xp.where(positive, value, constant(0, value))


@register("lommel_seeliger")
@dataclass(frozen=True, eq=False)
class LommelSeeliger(MixtureSampled):
    r"""Lommel–Seeliger: light scattered once, isotropically, in a sparse dark half-space.

    .. math::
        f_r(\omega_i, \omega_o) = \frac{w}{4\pi}\,\frac{1}{\mu_0 + \mu},
        \qquad \mu_0 = \cos\theta_i,\ \mu = \cos\theta_o,

    with w the single-scattering albedo of the particles (Hapke 2012, ch. 8, with an isotropic
    phase function, p = 1, and no multiple scattering). Lit from the camera (μ0 = μ, a full Moon)
    the radiance :math:`f\mu_0 E = wE/(8\pi)` is the same at every point of the disk: no limb
    darkening, unlike a Lambertian sphere (:math:`\rho\mu E/\pi`). Multiplied by a phase
    function and with an opposition surge it is the single-scattering term of
    :class:`~brdfkit.brdf.hapke.Hapke`.

    **Reciprocal**: yes (symmetric in μ0, μ). **Energy-conserving**: yes for w ≤ 1; the
    directional albedo is :func:`lommel_seeliger_albedo` ≤ w/2, exact in ``albedo``.

    Sampled by the cosine-weighted hemisphere (weight :math:`\pi f = w/(4(\mu_0+\mu))`).

    Parameters
    ----------
    w : single-scattering albedo in [0, 1] (``allow_unphysical=True``: up to 10⁶), scalar or per
        channel. Spec strings may call it ``single_scattering_albedo``.

    References
    ----------
    .. [1] H. Seeliger, "Zur Photometrie zerstreut reflectirender Substanzen",
           Sitzungsberichte der Bayerischen Akademie der Wissenschaften 18, 201–248, 1888.
    .. [2] B. Hapke, *Theory of Reflectance and Emittance Spectroscopy*, 2nd ed., Cambridge
           University Press, 2012, ch. 8.
    .. [3] S. Chandrasekhar, *Radiative Transfer*, Oxford, 1950, ch. I.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import LommelSeeliger
    >>> f = LommelSeeliger(w=0.5)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0249])
    >>> np.round(f.albedo(wo), 4)
    array([0.0878])
    """

    w: Any = 0.5
    allow_unphysical: bool = False
    spec_aliases: ClassVar[dict[str, str]] = {"single_scattering_albedo": "w"}
    domains: ClassVar[dict[str, Domain]] = {"w": ALBEDO}

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [cls(0.1), cls(0.6), cls(1.0), cls([0.3, 0.2, 0.12])]

    def _eval(self, wi: Array, wo: Array) -> Array:
        mu_0, mu = wi[..., 2:3], wo[..., 2:3]
        return safe_div(param(self.w, wi) / (4 * math.pi), mu_0 + mu)

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        return [cosine_component(xp.ones_like(wo[..., 2]))]

    def _albedo(self, wo: Array, hemisphere: str) -> Array:
        """Exact: :func:`lommel_seeliger_albedo` (nothing is transmitted)."""
        return lommel_seeliger_albedo(param(self.w, wo), wo[..., 2:3])


__all__ = ["LommelSeeliger", "lommel_seeliger_albedo"]
