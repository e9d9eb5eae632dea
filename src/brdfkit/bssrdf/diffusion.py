r"""Diffusion models of subsurface scattering: radial profiles :math:`R_d(r)` of a half-space.

Under collimated light entering a homogeneous half-space at a point, a diffusion model gives
the radiant exitance at distance r from it, per unit area and per unit power that entered:
:math:`R_d(r)` (m⁻²), with total diffuse reflectance :math:`\rho = 2\pi\int_0^\infty
R_d(r)\,r\,dr`. A separable BSSRDF (Jensen et al. 2001; pbrt's ``SeparableBSSRDF``) is then

.. math:: S(x_i, \omega_i; x_o, \omega_o) \approx \frac{1}{\pi}\,F_t(\omega_i)\,
          R_d(\lVert x_i - x_o\rVert)\,F_t(\omega_o)\,/\,c(\eta),

with :math:`F_t = 1 - F` the Fresnel transmittance. Each model here is a frozen dataclass of a
:class:`~brdfkit.bssrdf.Medium` with :meth:`~DiffusionProfile.profile`,
:meth:`~DiffusionProfile.total_reflectance`, and the radial importance sampling of
:mod:`brdfkit.bssrdf.profile_sampling`; :func:`invert_albedo` maps a diffuse colour back to the
single-scattering albedo. All models work in optical units (:math:`r\sigma_t`) and scale by
:math:`\sigma_t^2`, so a medium's extinction only sets the length scale.

The quantities they share (similarity theory, :class:`~brdfkit.bssrdf.Medium`):
:math:`\sigma_t' = \sigma_a + (1-g)\sigma_s`, :math:`\alpha' = (1-g)\sigma_s/\sigma_t'`, the
Fresnel moments of light inside, :math:`C_n = \int_0^1 F(-\mu, \eta)\,\mu^n\,d\mu`
(:func:`fresnel_moment`), and the dipole's real source at depth :math:`z_r = 1/\sigma_t'`.

References
----------
.. [1] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A practical model for subsurface
       light transport", SIGGRAPH 2001.
.. [2] E. d'Eon, "A better dipole", Technical report, 2012.
.. [3] R. Habel, P. H. Christensen, W. Jarosz, "Photon beam diffusion: a hybrid Monte Carlo
       method for subsurface scattering", Computer Graphics Forum 32(4) (EGSR), 2013.
.. [4] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., ch. 15
       "BSSRDFs" (§15.4–15.5), 2016.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar

import numpy as np
from scipy.optimize import brentq
from scipy.special import roots_legendre

from brdfkit._checks import as_float_array
from brdfkit.bssrdf.medium import ALBEDO, Medium, henyey_greenstein
from brdfkit.bssrdf.profile_sampling import RadialSampler
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel_dielectric

RADII = np.concatenate([[0.0], np.geomspace(1e-4, 200.0, 480)])
"""Optical radii (:math:`r\\sigma_t`) of the tables behind totals without a closed form and the
radial samplers: 0, then geometric from 10⁻⁴ to 200 mean free paths."""


def fresnel_moment(n: int, eta: Any) -> np.ndarray:
    r"""The n-th Fresnel moment of light reaching the boundary from inside,
    :math:`C_n(\eta) = \int_0^1 F(-\mu, \eta)\,\mu^n\,d\mu`, by Gauss–Legendre quadrature
    either side of the critical cosine (:func:`brdfkit.fresnel.fresnel_dielectric`).
    :math:`2C_1` is the internal diffuse reflectance :math:`F_{dr}`; pbrt-v3's
    ``FresnelMoment1`` and ``FresnelMoment2`` are polynomial fits of :math:`C_1, C_2`.

    Examples
    --------
    Water: light from inside is mostly reflected back (total internal reflection):

    >>> round(float(2 * fresnel_moment(1, 1.33)), 3)
    0.472
    >>> float(fresnel_moment(2, 1.0))
    0.0
    """
    eta = np.asarray(eta, dtype=float)
    x, w = roots_legendre(64)
    x, w = (x + 1) / 2, w / 2
    critical = np.sqrt(np.clip(1 - 1 / (eta * eta), 0.0, 1.0))[..., None]
    total = np.zeros(eta.shape)
    for lo, hi in ((0.0, critical), (critical, 1.0)):
        mu = lo + (hi - lo) * x
        total = total + np.sum((hi - lo) * w * fresnel_dielectric(-mu, eta[..., None]) * mu**n, -1)
    return total


@dataclass(frozen=True)
class DiffusionProfile:
    """A radial diffusion profile of a :class:`~brdfkit.bssrdf.Medium` (module docstring)."""

    medium: Medium

    name: ClassVar[str] = ""

    def profile(self, r: Any) -> np.ndarray:
        r""":math:`R_d(r)` per unit area and per unit power entering, ``r.shape + (C,)``."""
        r = as_float_array("r", r)
        sigma_t = np.atleast_1d(np.asarray(self.medium.sigma_t, dtype=float))
        return self._optical(r[..., None] * sigma_t) * sigma_t**2

    def total_reflectance(self) -> np.ndarray:
        r"""The total diffuse reflectance :math:`2\pi\int_0^\infty R_d(r)\,r\,dr`, ``(C,)``."""
        return self._table[1]

    def sampler(self, channel: int = 0) -> RadialSampler:
        """Importance sampling of the radius by :math:`2\\pi r R_d(r)` of one channel."""
        radii, density = self._table[0], self._table[2][..., channel]
        sigma_t = float(np.broadcast_to(self.medium.sigma_t, self._table[1].shape)[channel])
        return RadialSampler(radii / sigma_t, density * sigma_t)

    @cached_property
    def _table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Optical radii, totals and the radial densities :math:`2\\pi r R_d(r)` on them."""
        density = self._radial_density(RADII[:, None])
        return RADII, self._closed_total(density), density

    def _radial_density(self, r: np.ndarray) -> np.ndarray:
        """:math:`2\\pi r R_d(r)` in optical units."""
        return 2 * np.pi * r * self._optical(r)

    def _closed_total(self, density: np.ndarray) -> np.ndarray:
        """The total: in closed form where the model has one, else the trapezoid rule on
        :data:`RADII`."""
        return np.trapezoid(density, RADII, axis=0)

    def _optical(self, r: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _coefficients(self) -> dict[str, np.ndarray]:
        """Optical-unit coefficients: σa, σs', σt', α', and the Fresnel moments C1, C2."""
        m = self.medium
        one = np.atleast_1d(np.asarray(m.sigma_t, dtype=float))
        sigma_a, sigma_s_reduced = m.sigma_a / one, m.reduced_sigma_s / one
        return {
            "sigma_a": np.atleast_1d(sigma_a),
            "sigma_t": np.atleast_1d(sigma_a + sigma_s_reduced),
            "alpha": np.atleast_1d(m.reduced_albedo),
            "c1": np.atleast_1d(fresnel_moment(1, m.eta)),
            "c2": np.atleast_1d(fresnel_moment(2, m.eta)),
        }


def _dipole_terms(r, z_r, z_v, sigma_tr) -> tuple[np.ndarray, np.ndarray]:
    r"""The fluence-like and flux terms of a dipole (real source at depth :math:`z_r`,
    negative image at height :math:`z_v`):
    :math:`e^{-\sigma_{tr}d_r}/d_r - e^{-\sigma_{tr}d_v}/d_v` and
    :math:`z_r(1+\sigma_{tr}d_r)e^{-\sigma_{tr}d_r}/d_r^3
    + z_v(1+\sigma_{tr}d_v)e^{-\sigma_{tr}d_v}/d_v^3`, with :math:`d = \sqrt{r^2+z^2}`."""
    d_r, d_v = np.sqrt(r * r + z_r * z_r), np.sqrt(r * r + z_v * z_v)
    e_r, e_v = np.exp(-sigma_tr * d_r), np.exp(-sigma_tr * d_v)
    fluence = e_r / d_r - e_v / d_v
    flux = z_r * (1 + sigma_tr * d_r) * e_r / d_r**3 + z_v * (1 + sigma_tr * d_v) * e_v / d_v**3
    return fluence, flux


@dataclass(frozen=True)
class ClassicalDipole(DiffusionProfile):
    r"""The classical dipole of Jensen et al. (2001).

    With :math:`D = 1/(3\sigma_t')`, :math:`\sigma_{tr} = \sqrt{3\sigma_a\sigma_t'}`, the
    boundary's :math:`A = (1+F_{dr})/(1-F_{dr})` (:math:`F_{dr} = 2C_1`, the exact moment of
    which Jensen used the Egan–Hilgeman fit), :math:`z_r = 1/\sigma_t'` and
    :math:`z_v = z_r + 4AD`:

    .. math::
        R_d(r) = \frac{\alpha'}{4\pi}\Bigl[z_r(1+\sigma_{tr}d_r)\frac{e^{-\sigma_{tr}d_r}}
        {d_r^3} + z_v(1+\sigma_{tr}d_v)\frac{e^{-\sigma_{tr}d_v}}{d_v^3}\Bigr],\qquad
        \rho = \frac{\alpha'}{2}\bigl(1 + e^{-\frac43 A\sqrt{3(1-\alpha')}}\bigr)
        e^{-\sqrt{3(1-\alpha')}}.

    Claims: positive, decreasing in r, reciprocal (a function of distance only), total ≤ α' ≤ 1.
    Known limits (reproduced in ``benchmarks/bench_bssrdf.py``): only the flux term, a single
    source depth and the classical D make it too dark at high absorption and wrong as
    r → 0.

    References
    ----------
    .. [1] H. W. Jensen et al., "A practical model for subsurface light transport", SIGGRAPH
           2001, eqs. (4)–(5).
    .. [2] T. J. Farrell, M. S. Patterson, B. Wilson, "A diffusion theory model of spatially
           resolved, steady-state diffuse reflectance", Med. Phys. 19(4), 1992.

    Examples
    --------
    Chandrasekhar's exact value for this medium is 0.7527:

    >>> model = ClassicalDipole(Medium(albedo=0.99, eta=1.0))
    >>> round(float(model.total_reflectance()[0]), 4)
    0.7467
    """

    name: ClassVar[str] = "classical dipole"

    def _geometry(self) -> tuple[np.ndarray, ...]:
        c = self._coefficients()
        diffusion = 1 / (3 * c["sigma_t"])
        sigma_tr = np.sqrt(3 * c["sigma_a"] * c["sigma_t"])
        a = (1 + 2 * c["c1"]) / (1 - 2 * c["c1"])
        z_r = 1 / c["sigma_t"]
        return c["alpha"], sigma_tr, z_r, z_r + 4 * a * diffusion

    def _optical(self, r: np.ndarray) -> np.ndarray:
        alpha, sigma_tr, z_r, z_v = self._geometry()
        return alpha / (4 * np.pi) * _dipole_terms(r, z_r, z_v, sigma_tr)[1]

    def _closed_total(self, density: np.ndarray) -> np.ndarray:
        alpha, sigma_tr, z_r, z_v = self._geometry()
        return alpha / 2 * (np.exp(-sigma_tr * z_r) + np.exp(-sigma_tr * z_v))


@dataclass(frozen=True)
class BetterDipole(DiffusionProfile):
    r"""d'Eon's better dipole (2012).

    Grosjean's diffusion coefficient :math:`D = (2\sigma_a + \sigma_s')/(3\sigma_t'^2)`,
    :math:`\sigma_{tr} = \sqrt{\sigma_a/D}`, the extrapolation distance
    :math:`z_b = 2AD` with :math:`A = (1+3C_2)/(1-2C_1)`, the image at height
    :math:`z_v = z_r + 2z_b`, and the exitance of both the fluence and the flux through the
    Fresnel boundary, :math:`C_\phi = (1-2C_1)/4`, :math:`C_E = (1-3C_2)/2`:

    .. math::
        R_d(r) = C_\phi\,\frac{\alpha'}{4\pi D}\Bigl[\frac{e^{-\sigma_{tr}d_r}}{d_r}
        - \frac{e^{-\sigma_{tr}d_v}}{d_v}\Bigr] + C_E\,\frac{\alpha'}{4\pi}
        \Bigl[z_r(1+\sigma_{tr}d_r)\frac{e^{-\sigma_{tr}d_r}}{d_r^3}
        + z_v(1+\sigma_{tr}d_v)\frac{e^{-\sigma_{tr}d_v}}{d_v^3}\Bigr],

    .. math::
        \rho = C_\phi\,\frac{\alpha'}{2D\sigma_{tr}}\bigl(e^{-\sigma_{tr}z_r}
        - e^{-\sigma_{tr}z_v}\bigr) + C_E\,\frac{\alpha'}{2}\bigl(e^{-\sigma_{tr}z_r}
        + e^{-\sigma_{tr}z_v}\bigr).

    Claims: positive, reciprocal; closer to the transport solution than the classical dipole
    at high absorption (benchmark).

    References
    ----------
    .. [1] E. d'Eon, "A better dipole", 2012, eqs. (5)–(9).
    .. [2] M. Pharr et al., *PBRT*, 3rd ed., §15.5.2–15.5.4 (eqs. 15.24–15.32), 2016.

    Examples
    --------
    Chandrasekhar's exact value for this medium is 0.7527:

    >>> model = BetterDipole(Medium(albedo=0.99, eta=1.0))
    >>> round(float(model.total_reflectance()[0]), 4)
    0.7453
    """

    name: ClassVar[str] = "better dipole"

    def _geometry(self) -> tuple[np.ndarray, ...]:
        c = self._coefficients()
        diffusion = (2 * c["sigma_a"] + c["alpha"] * c["sigma_t"]) / (3 * c["sigma_t"] ** 2)
        sigma_tr = np.sqrt(c["sigma_a"] / diffusion)
        z_b = 2 * diffusion * (1 + 3 * c["c2"]) / (1 - 2 * c["c1"])
        z_r = 1 / c["sigma_t"]
        c_phi, c_e = (1 - 2 * c["c1"]) / 4, (1 - 3 * c["c2"]) / 2
        return c["alpha"], diffusion, sigma_tr, z_r, z_r + 2 * z_b, c_phi, c_e

    def _optical(self, r: np.ndarray) -> np.ndarray:
        alpha, diffusion, sigma_tr, z_r, z_v, c_phi, c_e = self._geometry()
        fluence, flux = _dipole_terms(r, z_r, z_v, sigma_tr)
        return alpha / (4 * np.pi) * (c_phi * fluence / diffusion + c_e * flux)

    def _closed_total(self, density: np.ndarray) -> np.ndarray:
        alpha, diffusion, sigma_tr, z_r, z_v, c_phi, c_e = self._geometry()
        e_r, e_v = np.exp(-sigma_tr * z_r), np.exp(-sigma_tr * z_v)
        # (e_r - e_v)/σtr, written to keep its limit e_r (z_v - z_r) at σtr = 0 (no absorption)
        gap = z_v - z_r
        spread = np.where(
            sigma_tr > 0, -np.expm1(-sigma_tr * gap) / np.where(sigma_tr > 0, sigma_tr, 1.0), gap
        )
        return alpha / 2 * (c_phi * e_r * spread / diffusion + c_e * (e_r + e_v))


@dataclass(frozen=True)
class PhotonBeamDiffusion(DiffusionProfile):
    r"""Photon beam diffusion (Habel, Christensen & Jarosz 2013), as pbrt-v3 evaluates it.

    Multiple scattering integrates better dipoles (:class:`BetterDipole`'s D, :math:`z_b`,
    :math:`C_\phi`, :math:`C_E`) of sources along the refracted beam, at depths
    :math:`z \sim \sigma_t' e^{-\sigma_t' z}` by ``samples`` stratified quantiles
    :math:`z_i = -\ln(1 - (i+\frac12)/n)/\sigma_t'`, each weighted by
    :math:`\alpha'^2` and the factor :math:`\kappa = 1 - e^{-2\sigma_t'(d_r + z)}` (which
    removes diffusion from sources too close to the point of exit); single scattering is
    added exactly, by quantiles of :math:`t \ge t_c = r\sqrt{\eta^2-1}` (depths seen inside
    the critical angle):

    .. math::
        R_{ss}(r) = \Bigl\langle \omega\,e^{-\sigma_t(d + t_c)}\,
        \frac{p(-\cos\theta_o)\,(1 - F(-\cos\theta_o, \eta))\,\cos\theta_o}{d^2}
        \Bigr\rangle_{t},\qquad d = \sqrt{r^2 + t^2},\ \cos\theta_o = t/d.

    Claims: positive, reciprocal; the most accurate of the diffusion models here against the
    random walk (benchmark).

    References
    ----------
    .. [1] R. Habel, P. H. Christensen, W. Jarosz, "Photon beam diffusion", EGSR 2013.
    .. [2] M. Pharr et al., *PBRT*, 3rd ed., §15.5.5–15.5.6 (``BeamDiffusionMS``,
           ``BeamDiffusionSS``), 2016.

    Examples
    --------
    A water-like boundary (the random walk sends back 0.646 ± 0.001 of the power that
    entered):

    >>> model = PhotonBeamDiffusion(Medium(albedo=0.99, eta=1.33))
    >>> round(float(model.total_reflectance()[0]), 4)
    0.673
    """

    samples: int = 100

    name: ClassVar[str] = "photon beam diffusion"

    def _optical(self, r: np.ndarray) -> np.ndarray:
        return self._multiple(r) + self._single(r)

    def _quantiles(self) -> np.ndarray:
        """The stratified quantiles :math:`-\\ln(1 - (i+\\frac12)/n)` of a unit exponential,
        on a trailing axis."""
        return -np.log1p(-(np.arange(self.samples) + 0.5) / self.samples)

    def _multiple(self, r: np.ndarray) -> np.ndarray:
        geometry = BetterDipole(self.medium)._geometry()
        alpha, diffusion, sigma_tr, z_r0, z_v0, c_phi, c_e = (x[..., None] for x in geometry)
        sigma_t, gap = 1 / z_r0, z_v0 - z_r0  # σt' and 2 z_b
        r = r[..., None]
        z_r = self._quantiles() / sigma_t
        fluence, flux = _dipole_terms(r, z_r, z_r + gap, sigma_tr)
        exitance = (c_phi * fluence / diffusion + c_e * flux) / (4 * np.pi)
        kappa = 1 - np.exp(-2 * sigma_t * (np.sqrt(r * r + z_r * z_r) + z_r))
        return np.mean(kappa * alpha * alpha * exitance, axis=-1)

    def _single(self, r: np.ndarray) -> np.ndarray:
        m = self.medium
        omega = np.atleast_1d(np.asarray(m.albedo, dtype=float))[..., None]
        eta = np.atleast_1d(np.asarray(m.eta, dtype=float))[..., None]
        r = r[..., None]
        t_critical = r * np.sqrt(np.maximum(eta * eta - 1, 0.0))
        t = t_critical + self._quantiles()
        d = np.sqrt(r * r + t * t)
        cos_o = t / d
        transmit = 1 - fresnel_dielectric(-cos_o, eta)
        phase = henyey_greenstein(-cos_o, np.asarray(m.g, dtype=float)[..., None])
        term = omega * np.exp(-(d + t_critical)) * phase * transmit * cos_o / (d * d)
        return np.mean(term, axis=-1)


def invert_albedo(
    model: type[DiffusionProfile], diffuse_albedo: Any, eta: float = 1.0, g: float = 0.0
) -> np.ndarray:
    r"""The single-scattering albedo ω whose medium the ``model`` gives the total diffuse
    reflectance ``diffuse_albedo`` (an artist's colour), per channel: the root of
    :math:`\rho(\omega) = A` in [0, 1] by Brent's method (ρ increases with ω), as pbrt-v3's
    ``SubsurfaceFromDiffuse`` inverts its table.

    Raises
    ------
    brdfkit.errors.ParameterError
        A colour outside [0, ρ(1)], the reflectance of a medium that absorbs nothing.

    Examples
    --------
    >>> omega = invert_albedo(BetterDipole, [0.8, 0.5, 0.2], eta=1.33)
    >>> BetterDipole(Medium(omega, eta=1.33)).total_reflectance().round(6).tolist()
    [0.8, 0.5, 0.2]
    """
    targets = np.atleast_1d(as_float_array("diffuse_albedo", diffuse_albedo))
    ALBEDO.check("diffuse_albedo", targets)

    def total(omega: float) -> float:
        return float(model(Medium(omega, eta=eta, g=g)).total_reflectance()[0])

    brightest = total(1.0)
    if np.any(targets > brightest):
        raise ParameterError(
            f"diffuse_albedo must be at most {brightest:.4f} for the {model.name} at eta="
            f"{eta}; got {float(targets.max()):g}"
        )
    return np.array([brentq(lambda w, a=a: total(w) - a, 0.0, 1.0, xtol=1e-12) for a in targets])


__all__ = [
    "RADII",
    "BetterDipole",
    "ClassicalDipole",
    "DiffusionProfile",
    "PhotonBeamDiffusion",
    "fresnel_moment",
    "invert_albedo",
]
