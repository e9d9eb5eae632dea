r"""Chandrasekhar's exact reflectance of a semi-infinite isotropically scattering medium.

For isotropic scattering with single-scattering albedo ω, no boundary (index-matched) and
collimated light arriving at :math:`\mu_0 = \cos\theta_0`, the fraction of the incident power
that the half-space sends back (its plane albedo, all orders of scattering) is exact:

.. math:: R(\mu_0) = 1 - H(\mu_0)\sqrt{1-\omega},

where H is Chandrasekhar's H-function, the solution of the nonlinear integral equation

.. math::
    H(\mu) = 1 + \frac{\omega}{2}\,\mu\,H(\mu)\int_0^1 \frac{H(\mu')}{\mu+\mu'}\,d\mu',
    \quad\text{equivalently}\quad
    \frac{1}{H(\mu)} = \sqrt{1-\omega} + \frac{\omega}{2}\int_0^1
    \frac{\mu' H(\mu')}{\mu+\mu'}\,d\mu'.

:func:`h_function` solves the second form on Gauss–Legendre nodes by Newton's method (plain
iteration of it converges slowly as ω → 1 and not at all at ω = 1) and evaluates H anywhere by
the same quadrature (Nyström). It is the reference the Monte Carlo random walk of
:mod:`brdfkit.bssrdf.random_walk` is held to.

References
----------
.. [1] S. Chandrasekhar, *Radiative Transfer*, Oxford, 1950, §§26–27, 45 (Table XI: H for
       conservative isotropic scattering, H(1) = 2.9078).
.. [2] K. M. Case, P. F. Zweifel, *Linear Transport Theory*, Addison-Wesley, 1967.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from scipy.special import roots_legendre

from brdfkit._array import check_param
from brdfkit._checks import as_float_array
from brdfkit.bssrdf.medium import ALBEDO

NODES = 64
"""Gauss–Legendre nodes on [0, 1] of the H-equation's quadrature (H agrees with 128 nodes and
with Chandrasekhar's closed-form integral to 1e-10)."""


@cache
def _nodes() -> tuple[np.ndarray, np.ndarray]:
    x, w = roots_legendre(NODES)
    return (x + 1) / 2, w / 2


@cache
def _h_at_nodes(albedo: float) -> np.ndarray:
    """H at the quadrature nodes: Newton's method on :math:`H_i(\\gamma + \\sum_j K_{ij} H_j)
    = 1`, :math:`K_{ij} = \\frac{\\omega}{2} w_j\\mu_j/(\\mu_i+\\mu_j)`, from H = 1."""
    mu, weight = _nodes()
    kernel = 0.5 * albedo * weight * mu / (mu[:, None] + mu)
    gamma = np.sqrt(1 - albedo)
    h = np.ones(NODES)
    for _ in range(50):
        inner = gamma + kernel @ h
        step = np.linalg.solve(np.diag(inner) + h[:, None] * kernel, 1 - h * inner)
        h += step
        if np.max(np.abs(step)) < 1e-15:
            break
    return h


def h_function(mu: Any, albedo: float) -> np.ndarray:
    r"""Chandrasekhar's H-function of isotropic scattering, :math:`H(\mu)` for albedo ω.

    Parameters
    ----------
    mu : cosines in [0, 1] (any shape).
    albedo : single-scattering albedo ω in [0, 1].

    Returns
    -------
    H(μ), the shape of ``mu``: 1 at μ = 0, increasing in μ and in ω; at ω = 1,
    H(0.5) = 2.0128 and H(1) = 2.9078 (Chandrasekhar's Table XI).

    References
    ----------
    .. [1] S. Chandrasekhar, *Radiative Transfer*, 1950, §27 and Table XI.

    Examples
    --------
    >>> h_function([0.0, 0.5, 1.0], 1.0).round(4).tolist()
    [1.0, 2.0128, 2.9078]
    """
    omega = float(ALBEDO.check("albedo", float(albedo)))
    mu = check_param("mu", as_float_array("mu", mu), 0.0, 1.0)
    nodes, weight = _nodes()
    h = _h_at_nodes(omega)
    integral = np.sum(weight * nodes * h / (mu[..., None] + nodes), axis=-1)
    return 1.0 / (np.sqrt(1 - omega) + 0.5 * omega * integral)


def chandrasekhar_reflectance(cos_theta_i: Any, albedo: float) -> np.ndarray:
    r"""The exact total reflectance :math:`R(\mu_0) = 1 - H(\mu_0)\sqrt{1-\omega}` of a
    semi-infinite isotropically scattering medium at an index-matched boundary, for
    collimated light at :math:`\mu_0 = \cos\theta_i` (all orders of scattering).

    Parameters
    ----------
    cos_theta_i : cosine of the incident direction, in [0, 1].
    albedo : single-scattering albedo ω in [0, 1].

    References
    ----------
    .. [1] S. Chandrasekhar, *Radiative Transfer*, 1950, §45, eq. (50) (the plane albedo).

    Examples
    --------
    A conservative medium reflects everything; half-albedo milk-like media far less:

    >>> float(chandrasekhar_reflectance(1.0, 1.0))
    1.0
    >>> chandrasekhar_reflectance([1.0, 0.5], 0.5).round(4).tolist()
    [0.1152, 0.1601]
    """
    omega = float(ALBEDO.check("albedo", float(albedo)))
    mu = check_param("cos_theta_i", as_float_array("cos_theta_i", cos_theta_i), 0.0, 1.0)
    return 1.0 - h_function(mu, omega) * np.sqrt(1 - omega)


__all__ = ["NODES", "chandrasekhar_reflectance", "h_function"]
