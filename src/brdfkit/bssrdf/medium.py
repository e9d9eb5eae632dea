r"""A homogeneous scattering medium below a smooth dielectric boundary.

A medium is given by its single-scattering albedo :math:`\omega = \sigma_s/\sigma_t`, its
extinction coefficient :math:`\sigma_t` (or its mean free path :math:`\ell = 1/\sigma_t`), its
phase function (Henyey–Greenstein with asymmetry g; g = 0 is isotropic) and the relative index
of refraction :math:`\eta = n_\text{inside}/n_\text{outside}` of its boundary. From these follow
the quantities the diffusion models use (similarity theory):

.. math::
    \sigma_s = \omega\sigma_t,\quad \sigma_a = (1-\omega)\sigma_t,\quad
    \sigma_s' = (1-g)\,\sigma_s,\quad \sigma_t' = \sigma_a + \sigma_s',\quad
    \alpha' = \sigma_s'/\sigma_t'.

Parameters broadcast like any brdfkit parameter: ``albedo=[0.9, 0.7, 0.5]`` is an RGB medium
(the random walk takes one channel at a time). Lengths are in the unit of ``1/sigma_t``.

References
----------
.. [1] S. Chandrasekhar, *Radiative Transfer*, Oxford, 1950, ch. I.
.. [2] L. G. Henyey, J. L. Greenstein, "Diffuse radiation in the galaxy", ApJ 93, 70–83, 1941.
.. [3] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §11.1–11.3
       (media, phase functions) and §15.5 (similarity theory), 2016.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit.params import Domain, check_domains

ALBEDO = Domain(0.0, 1.0, hint="single-scattering albedo ω = σs/σt")
EXTINCTION = Domain(0.0, math.inf, lo_open=True, hi_open=True, hint="extinction σt = 1/ℓ")
ASYMMETRY = Domain(-1.0, 1.0, lo_open=True, hi_open=True, hint="Henyey–Greenstein mean cosine g")
INDEX = Domain(0.0, math.inf, lo_open=True, hi_open=True, hint="relative index n_in/n_out")


def henyey_greenstein(cos_theta: Any, g: Any) -> np.ndarray:
    r"""The Henyey–Greenstein phase function of the scattering angle θ between the direction
    of travel before and after scattering, per steradian:

    .. math:: p(\cos\theta) = \frac{1}{4\pi}\,\frac{1-g^2}{(1+g^2-2g\cos\theta)^{3/2}},

    normalised (:math:`\oint p\,d\omega = 1`) with mean cosine :math:`\langle\cos\theta\rangle
    = g`; g > 0 scatters forwards, g = 0 is isotropic (:math:`1/4\pi`). (Hapke's form in the
    phase angle, :func:`brdfkit.brdf.hapke.henyey_greenstein`, is this one times 4π at
    cos θ = −cos g.)

    References
    ----------
    .. [1] L. G. Henyey, J. L. Greenstein, "Diffuse radiation in the galaxy", ApJ 93, 1941.

    Examples
    --------
    >>> round(float(henyey_greenstein(0.3, 0.0) * 4 * np.pi), 12)
    1.0
    """
    cos_theta, g = np.asarray(cos_theta, dtype=float), np.asarray(g, dtype=float)
    base = 1 + g * g - 2 * g * cos_theta
    return (1 - g * g) / (4 * np.pi * base * np.sqrt(base))


def sample_henyey_greenstein(u: Any, g: Any) -> np.ndarray:
    r"""The cosine of a scattering angle drawn from :func:`henyey_greenstein` by inverting its
    CDF, for uniforms ``u`` in [0, 1):

    .. math::
        \cos\theta = \frac{1}{2g}\Bigl(1 + g^2 - \Bigl(\frac{1-g^2}{1-g+2gu}\Bigr)^2\Bigr),
        \qquad \cos\theta = 2u - 1 \text{ for } g = 0,

    increasing in u (u = 0 gives −1, u → 1 gives 1). For :math:`|g| < 10^{-3}` the isotropic
    form is used (the two differ by less than 2|g|, and the first cancels badly).

    References
    ----------
    .. [1] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 3rd ed., §15.2.3, 2016.

    Examples
    --------
    >>> sample_henyey_greenstein(np.array([0.0, 0.5]), 0.0).tolist()
    [-1.0, 0.0]
    >>> round(float(sample_henyey_greenstein(0.5, 0.5)), 6)  # the median of g = 0.5
    0.6875
    """
    u, g = np.asarray(u, dtype=float), np.asarray(g, dtype=float)
    isotropic = np.abs(g) < 1e-3
    safe_g = np.where(isotropic, 0.5, g)
    ratio = (1 - safe_g * safe_g) / (1 - safe_g + 2 * safe_g * u)
    anisotropic = (1 + safe_g * safe_g - ratio * ratio) / (2 * safe_g)
    return np.clip(np.where(isotropic, 2 * u - 1, anisotropic), -1.0, 1.0)


@dataclass(frozen=True)
class Medium:
    r"""A homogeneous medium: albedo ω, extinction σt, Henyey–Greenstein g and boundary η.

    Parameters
    ----------
    albedo : single-scattering albedo :math:`\omega = \sigma_s/\sigma_t` in [0, 1].
    sigma_t : extinction coefficient :math:`\sigma_t > 0` (per unit length; 1 measures lengths
        in mean free paths).
    g : Henyey–Greenstein asymmetry in (−1, 1); 0 is isotropic scattering.
    eta : relative index of refraction of the boundary, :math:`n_\text{inside}/n_\text{outside}`
        (1: index-matched, 1.33 water, 1.4 skin, 1.5 marble).

    The derived coefficients (module docstring) are properties; :meth:`from_mean_free_path`
    builds a medium from ℓ = 1/σt.

    References
    ----------
    .. [1] S. Chandrasekhar, *Radiative Transfer*, 1950.
    .. [2] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A practical model for
           subsurface light transport", SIGGRAPH 2001 (the reduced coefficients).

    Examples
    --------
    >>> m = Medium(albedo=0.9, sigma_t=2.0, g=0.5, eta=1.33)
    >>> [round(float(x), 6) for x in (m.sigma_a, m.reduced_sigma_t, m.reduced_albedo)]
    [0.2, 1.1, 0.818182]
    >>> float(Medium.from_mean_free_path(0.5, 0.25).sigma_t)
    4.0
    >>> Medium(albedo=1.2)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: albedo must be in [0.0, 1.0]; got 1.2 ...
    """

    albedo: Any
    sigma_t: Any = 1.0
    g: Any = 0.0
    eta: Any = 1.0

    domains: ClassVar[dict[str, Domain]] = {
        "albedo": ALBEDO,
        "sigma_t": EXTINCTION,
        "g": ASYMMETRY,
        "eta": INDEX,
    }

    def __post_init__(self) -> None:
        check_domains(self)

    @classmethod
    def from_mean_free_path(
        cls, albedo: Any, mean_free_path: Any, g: Any = 0.0, eta: Any = 1.0
    ) -> Medium:
        """The medium of albedo ω whose mean free path is ℓ: :math:`\\sigma_t = 1/\\ell`."""
        EXTINCTION.check("mean_free_path", mean_free_path)
        return cls(albedo, 1.0 / np.asarray(mean_free_path, dtype=float), g, eta)

    @property
    def mean_free_path(self) -> np.ndarray:
        r""":math:`\ell = 1/\sigma_t`."""
        return 1.0 / np.asarray(self.sigma_t, dtype=float)

    @property
    def sigma_s(self) -> np.ndarray:
        r"""Scattering coefficient :math:`\sigma_s = \omega\sigma_t`."""
        return np.asarray(self.albedo, dtype=float) * self.sigma_t

    @property
    def sigma_a(self) -> np.ndarray:
        r"""Absorption coefficient :math:`\sigma_a = (1-\omega)\sigma_t`."""
        return (1 - np.asarray(self.albedo, dtype=float)) * self.sigma_t

    @property
    def reduced_sigma_s(self) -> np.ndarray:
        r"""Reduced scattering coefficient :math:`\sigma_s' = (1-g)\sigma_s`."""
        return (1 - np.asarray(self.g, dtype=float)) * self.sigma_s

    @property
    def reduced_sigma_t(self) -> np.ndarray:
        r"""Reduced extinction :math:`\sigma_t' = \sigma_a + \sigma_s'`."""
        return self.sigma_a + self.reduced_sigma_s

    @property
    def reduced_albedo(self) -> np.ndarray:
        r"""Reduced albedo :math:`\alpha' = \sigma_s'/\sigma_t'` (0 where :math:`\sigma_t' = 0`)."""
        total = self.reduced_sigma_t
        return np.divide(self.reduced_sigma_s, total, out=np.zeros_like(total), where=total > 0)

    def phase(self, cos_theta: Any) -> np.ndarray:
        """The medium's phase function at the scattering angle's cosine
        (:func:`henyey_greenstein`)."""
        return henyey_greenstein(cos_theta, self.g)


__all__ = [
    "ALBEDO",
    "ASYMMETRY",
    "EXTINCTION",
    "INDEX",
    "Medium",
    "henyey_greenstein",
    "sample_henyey_greenstein",
]
