r"""Christensen & Burley's normalized diffusion: an empirical profile that artists drive.

The profile is a sum of two exponentials whose integral is the surface albedo A itself:

.. math::
    R_d(r) = A\,s\,\frac{e^{-s r/\ell} + e^{-s r/(3\ell)}}{8\pi\,\ell\,r},\qquad
    2\pi\int_0^\infty R_d(r)\,r\,dr = A,

with ℓ a length of the medium and s a shape factor Christensen and Burley fitted to Monte
Carlo references of a searchlight (collimated light at normal incidence). Here
:math:`s = 3.5 + 100\,(A - 0.33)^4` (their searchlight fit) with the diffusion length
:math:`\ell = 1/\sigma_{tr}`, :math:`\sigma_{tr} = \sqrt{3\sigma_a\sigma_t'}`: measured against
brdfkit's random walk (``benchmarks/bench_bssrdf.py``, A from photon beam diffusion) this
pairing puts 4–11 % of the power at the wrong radius for η ∈ {1.33, 1.5} and
ω ∈ [0.1, 0.99] (up to 18 % at η = 1, ω = 0.99), while the paper's fit for its "diffuse mean
free path", :math:`s = 1.85 - A + 7\lvert A - 0.8\rvert^3`, with the same length misplaces
up to half of it at high albedo (the papers' length conventions differ).
The radial density
:math:`2\pi r R_d(r)/A = \tfrac14\,\tfrac{s}{\ell}e^{-sr/\ell} + \tfrac34\,\tfrac{s}{3\ell}
e^{-sr/(3\ell)}` is a mixture of two exponentials.

The model has no medium of its own: A is a colour. :class:`NormalizedDiffusion` takes it from
a :class:`~brdfkit.bssrdf.Medium` through a physical model's total reflectance (photon beam
diffusion by default), or as given.

References
----------
.. [1] P. H. Christensen, B. Burley, "Approximate reflectance profiles for efficient
       subsurface scattering", Pixar Technical Memo 15-04, 2015, eqs. (3)–(8).
.. [2] B. Burley, "Extending the Disney BRDF to a BSDF with integrated subsurface
       scattering", SIGGRAPH Course Notes, 2015.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit.bssrdf.diffusion import DiffusionProfile, PhotonBeamDiffusion
from brdfkit.bssrdf.medium import ALBEDO


def shape_factor(albedo: Any) -> np.ndarray:
    r"""Christensen and Burley's searchlight fit :math:`s(A) = 3.5 + 100\,(A - 0.33)^4`
    (applied here with ℓ = 1/σtr, module docstring).

    Examples
    --------
    >>> shape_factor([0.33, 0.8]).round(4).tolist()
    [3.5, 8.3797]
    """
    a = np.asarray(albedo, dtype=float)
    return 3.5 + 100 * (a - 0.33) ** 4


@dataclass(frozen=True)
class NormalizedDiffusion(DiffusionProfile):
    r"""The normalized diffusion profile (module docstring) of a medium.

    Parameters
    ----------
    medium : the :class:`~brdfkit.bssrdf.Medium`; its mean free path sets ℓ.
    surface_albedo : the colour A in [0, 1]; ``None`` takes the total reflectance of
        :class:`~brdfkit.bssrdf.diffusion.PhotonBeamDiffusion` of ``medium``.

    Claims: positive, reciprocal, total exactly A (energy-conserving for A ≤ 1).

    References
    ----------
    .. [1] P. H. Christensen, B. Burley, Pixar Technical Memo 15-04, 2015.

    Examples
    --------
    >>> from brdfkit.bssrdf import Medium
    >>> model = NormalizedDiffusion(Medium(albedo=0.9, eta=1.33), surface_albedo=[0.8, 0.4])
    >>> model.total_reflectance().round(6).tolist()
    [0.8, 0.4]
    """

    surface_albedo: Any = None

    name: ClassVar[str] = "normalized diffusion"

    def __post_init__(self) -> None:
        if self.surface_albedo is not None:
            ALBEDO.check("surface_albedo", self.surface_albedo)

    def colour(self) -> np.ndarray:
        """The albedo A, ``(C,)``."""
        if self.surface_albedo is not None:
            return np.atleast_1d(np.asarray(self.surface_albedo, dtype=float))
        return PhotonBeamDiffusion(self.medium).total_reflectance()

    def _rate(self) -> tuple[np.ndarray, np.ndarray]:
        """A and the rate :math:`s/\\ell_d` in optical units (ℓ = 1)."""
        a, m = self.colour(), self.medium
        one = np.atleast_1d(np.asarray(m.sigma_t, dtype=float))
        sigma_tr = np.sqrt(3 * m.sigma_a * m.reduced_sigma_t) / one
        return a, shape_factor(a) * np.atleast_1d(sigma_tr)

    def _optical(self, r: np.ndarray) -> np.ndarray:
        a, rate = self._rate()
        with np.errstate(divide="ignore", invalid="ignore"):
            return a * rate * (np.exp(-rate * r) + np.exp(-rate * r / 3)) / (8 * np.pi * r)

    def _radial_density(self, r: np.ndarray) -> np.ndarray:
        a, rate = self._rate()
        return a * rate * (np.exp(-rate * r) + np.exp(-rate * r / 3)) / 4

    def _closed_total(self, density: np.ndarray) -> np.ndarray:
        return self.colour()


__all__ = ["NormalizedDiffusion", "shape_factor"]
