"""Fresnel reflectance of smooth interfaces: exact dielectric and conductor, Schlick, IOR presets.

Conventions (the same as Mitsuba 3's ``fresnel.h`` and :func:`brdfkit.geometry.refract`):

- ``cos_theta_i`` is the cosine between the surface normal and the direction towards the light,
  in ``[-1, 1]``. The normal points *out* into the exterior medium: ``cos_theta_i ≥ 0`` means the
  light arrives from outside, ``cos_theta_i < 0`` from inside.
- ``eta`` is the *relative* index of refraction ``η = n_inside / n_outside`` (``n_t / n_i`` for
  light arriving from outside). For glass in air ``eta ≈ 1.5``; light leaving the glass is
  handled by a negative cosine, never by passing ``1/eta``.
- Conductors have the complex relative index ``η + iκ`` (``eta``, ``k``); the metal is opaque,
  so only ``|cos_theta_i|`` matters there.

Every function is elementwise and broadcasts its arguments against each other; for a channel
axis pass ``cos_theta_i[..., None]`` with channel-valued ``eta`` of shape ``(C,)``. Inputs may
be NumPy or torch (or JAX) arrays or Python scalars; the dtype of the array inputs is kept
and gradients flow to every argument. Cosines up to a few ulps beyond ±1 (rounding in a
normalisation) are accepted and clamped.

References
----------
.. [1] M. Born and E. Wolf, *Principles of Optics*, 7th ed., §1.5 and §14.2, Cambridge, 1999.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §9.3, 2023.
.. [3] W. Jakob et al., Mitsuba 3, ``include/mitsuba/render/fresnel.h`` and ``render/ior.h``.
.. [4] C. Schlick, "An inexpensive BRDF model for physically-based rendering", *Computer
       Graphics Forum* 13(3):233-246, 1994.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from brdfkit._array import (
    Array,
    asarrays,
    check_finite,
    check_param,
    clamp,
    namespace,
    safe_div,
    safe_sqrt,
    where,
)
from brdfkit.data import colorimetry

# --------------------------------------------------------------------------- presets
IOR: dict[str, float] = {
    "vacuum": 1.0,
    "helium": 1.000036,
    "hydrogen": 1.000132,
    "air": 1.000277,
    "carbon dioxide": 1.00045,
    "water": 1.3330,
    "acetone": 1.36,
    "ethanol": 1.361,
    "carbon tetrachloride": 1.461,
    "glycerol": 1.4729,
    "benzene": 1.501,
    "silicone oil": 1.52045,
    "bromine": 1.661,
    "water ice": 1.31,
    "fused quartz": 1.458,
    "pyrex": 1.470,
    "acrylic glass": 1.49,
    "polypropylene": 1.49,
    "glass": 1.5,
    "bk7": 1.5046,
    "sodium chloride": 1.544,
    "amber": 1.55,
    "pet": 1.5750,
    "diamond": 2.419,
}
"""Absolute refractive indices of dielectrics at ~589 nm (sodium D line), 0-20 °C.

Source: E. Hecht, *Optics*, 4th ed., Addison-Wesley 2002, as tabulated in Mitsuba 3
``include/mitsuba/render/ior.h`` (same names and values, so ``int_ior='bk7'`` means the same
thing in both). ``"glass"`` = 1.5 is the conventional rendering value (F0 = 0.04), not a
measurement. A relative index is a ratio of two entries: Mitsuba's default dielectric is
``IOR["bk7"] / IOR["air"]``.
"""

CONDUCTORS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "Ag": ((0.1552762, 0.116727956, 0.13838764), (4.8283544, 3.1222224, 2.1469011)),
    "Al": ((1.6575009, 0.8804047, 0.52124447), (9.223811, 6.269502, 4.837004)),
    "Au": ((0.14303598, 0.37530708, 1.4420453), (3.982997, 2.3855565, 1.6033592)),
    "Cr": ((4.3696675, 2.9165053, 1.6549046), (5.206547, 4.231306, 3.7546988)),
    "Cu": ((0.20100547, 0.9237495, 1.1022154), (3.9132621, 2.4530451, 2.1420898)),
    "W": ((4.3708167, 3.3002465, 2.9984074), (3.5006406, 2.604874, 2.2732332)),
}
"""Linear-sRGB complex indices ``((η_r, η_g, η_b), (κ_r, κ_g, κ_b))`` of metals in air.

Source: the spectral tables ``data/ior/<name>.eta.spd`` / ``.k.spd`` shipped with Mitsuba 3
(from the luxpop.com database, 300-885 nm), reduced to RGB exactly as Mitsuba's RGB variants do
when loading ``conductor(material='<name>')`` (``spectrum_list_to_srgb``: CIE 1931 2° XYZ under
an equal-energy illuminant, normalised by ∫ȳ, then the sRGB matrix, unbounded). The values are
Mitsuba 3.9 ``scalar_rgb``'s own float32 numbers, so a comparison with a Mitsuba conductor of
the same name is exact; :func:`rgb_from_spectrum` re-derives them (colour-science's
integration, restated in :mod:`brdfkit.data.colorimetry`) from the spectral tables to within
0.32 % (Mitsuba integrates a 5 nm CMF table by a 1000-step sum).
"""


def dielectric(name: str) -> float:
    """The absolute refractive index of the dielectric ``name`` in :data:`IOR` (case-insensitive).

    Raises
    ------
    ValueError
        For an unknown name, listing the known ones.

    Examples
    --------
    >>> dielectric("Diamond")
    2.419
    >>> float(f0_from_ior(dielectric("glass")).round(4))
    0.04
    """
    key = name.strip().lower()
    if key not in IOR:
        raise ValueError(f"name must be a dielectric in IOR ({', '.join(IOR)}); got {name!r}")
    return IOR[key]


def conductor(name: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The RGB complex index ``(eta, k)`` of the metal ``name`` in :data:`CONDUCTORS`.

    The lookup is case-insensitive (``"au"`` finds ``"Au"``). Python floats are returned so that
    they take the dtype of the arrays they meet (float32 stays float32).

    Raises
    ------
    ValueError
        For an unknown name, listing the known ones.

    Examples
    --------
    >>> import numpy as np
    >>> eta, k = conductor("au")
    >>> f0_from_conductor(np.array(eta), np.array(k)).round(4).tolist()  # gold, head on
    [0.9667, 0.802, 0.3241]
    """
    by_lower = {key.lower(): key for key in CONDUCTORS}
    key = by_lower.get(name.strip().lower())
    if key is None:
        raise ValueError(
            f"name must be a metal in CONDUCTORS ({', '.join(CONDUCTORS)}); got {name!r}"
        )
    return CONDUCTORS[key]


def rgb_from_spectrum(wavelengths: Any, values: Any) -> np.ndarray:
    """Reduce a spectral quantity (an index η(λ) or κ(λ)) to linear-sRGB values, as Mitsuba does.

    ``X = ∫ v(λ) x̄(λ) dλ / ∫ ȳ(λ) dλ`` (likewise Y, Z) with the CIE 1931 2° observer over
    360-830 nm at 1 nm and ``v`` interpolated linearly (held constant beyond the measured range),
    then ``RGB = M_sRGB · XYZ`` with no chromatic adaptation, negatives clamped to 0. This is
    Mitsuba 3's ``spectrum_list_to_srgb(bounded=False, d65=False)`` recipe, which produced
    :data:`CONDUCTORS`; a flat spectrum of 1 maps to (1.205, 0.948, 0.909), not to grey, in
    both. The integration is colour-science's ``sd_to_XYZ(..., method="Integration")`` under
    illuminant E and its sRGB matrix, restated in :mod:`brdfkit.data.colorimetry` (the tests
    hold them equal to ~1e-12) rather than imported: colour-science is a 94 MiB install for a
    table and a sum.

    Parameters
    ----------
    wavelengths : (N,) increasing wavelengths in nanometres.
    values : (N,) the spectral values.

    Returns
    -------
    (3,) float64 linear-sRGB values.

    References
    ----------
    .. [1] CIE 015:2018, *Colorimetry*, 4th ed.; IEC 61966-2-1 (sRGB).
    .. [2] Mitsuba 3, ``src/core/spectrum.cpp``, ``spectrum_list_to_srgb``.

    Examples
    --------
    >>> rgb_from_spectrum([400.0, 700.0], [1.0, 1.0]).round(3).tolist()
    [1.205, 0.948, 0.909]
    """
    wavelengths = np.asarray(wavelengths, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    if wavelengths.ndim != 1 or wavelengths.shape != values.shape or wavelengths.size < 2:
        raise ValueError(
            "wavelengths and values must be 1-d of the same length >= 2; got shapes "
            f"{wavelengths.shape} and {values.shape}"
        )
    check_finite("wavelengths", wavelengths)
    check_finite("values", values)
    if not np.all(np.diff(wavelengths) > 0):
        raise ValueError("wavelengths must be strictly increasing (nm)")
    grid = colorimetry.observer()[0]
    # np.interp: linear inside the table, the end values held outside (as documented above).
    xyz = colorimetry.tristimulus(np.interp(grid, wavelengths, values))
    rgb = colorimetry.XYZ_TO_LINEAR_SRGB @ xyz
    return np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)


# --------------------------------------------------------------------------- validation
def _cosine(cos_theta_i: Array) -> Array:
    """Validate a cosine (a few ulps of slack beyond ±1) and clamp it into [-1, 1]."""
    slack = 4 * float(namespace(cos_theta_i).finfo(cos_theta_i.dtype).eps)
    check_param("cos_theta_i", cos_theta_i, -1.0, 1.0, slack=slack)
    return clamp(cos_theta_i, -1.0, 1.0)


# --------------------------------------------------------------------------- dielectrics
def _dielectric(cos_theta_i: Any, eta: Any) -> tuple[Array, Array, Array, Array, Array]:
    """``(Rs, Rp, cos_theta_t, eta_it, eta_ti)`` of a dielectric interface (see :func:`fresnel`)."""
    cos_theta_i, eta = asarrays(cos_theta_i, eta)
    check_param("eta", eta, 0.0, lo_open=True, hint="relative index n_in/n_out")
    cos_theta_i = _cosine(cos_theta_i)
    xp = namespace(cos_theta_i, eta)
    outside = cos_theta_i >= 0
    eta_it = xp.where(outside, eta, 1 / eta)
    eta_ti = xp.where(outside, 1 / eta, eta)
    cos_i = xp.abs(cos_theta_i)
    cos_t_sqr = 1 - (1 - cos_i * cos_i) * eta_ti * eta_ti
    cos_t = safe_sqrt(cos_t_sqr)
    a_s = safe_div(cos_i - eta_it * cos_t, cos_i + eta_it * cos_t)
    a_p = safe_div(eta_it * cos_i - cos_t, eta_it * cos_i + cos_t)
    # Total internal reflection, and grazing incidence, reflect everything; a matched index
    # (no interface at all) reflects nothing, even at grazing incidence (as in Mitsuba).
    total = (cos_t_sqr <= 0) | (cos_i == 0)
    matched = eta == 1
    r_s = where(matched, 0.0, where(total, 1.0, a_s * a_s))
    r_p = where(matched, 0.0, where(total, 1.0, a_p * a_p))
    cos_theta_t = xp.where(outside, -cos_t, cos_t)
    return r_s, r_p, cos_theta_t, eta_it, eta_ti


def fresnel(cos_theta_i: Any, eta: Any) -> tuple[Array, Array, Array, Array]:
    """Unpolarised dielectric Fresnel reflectance with the refraction data a BSDF needs.

    With ``η_it = η`` for ``cos θi ≥ 0`` (light from outside) and ``1/η`` otherwise, Snell's law
    gives ``cos²θt = 1 − (1 − cos²θi)/η_it²``; then (Born & Wolf §1.5.2)

    ``r_s = (cos θi − η_it cos θt) / (cos θi + η_it cos θt)``,
    ``r_p = (η_it cos θi − cos θt) / (η_it cos θi + cos θt)``, ``F = (r_s² + r_p²) / 2``,

    with ``F = 1`` under total internal reflection (``cos²θt ≤ 0``) and at grazing incidence,
    and ``F = 0`` for a matched index (``η = 1``).

    Parameters
    ----------
    cos_theta_i : cosine of the incident direction with the (outward) normal, in [-1, 1].
    eta : relative index ``n_inside / n_outside`` (> 0).

    Returns
    -------
    F : unpolarised reflectance.
    cos_theta_t : cosine of the refracted direction, of the opposite sign to ``cos_theta_i``
        (0 under total internal reflection).
    eta_it : relative index in the direction of travel, ``n_t / n_i``.
    eta_ti : its reciprocal, the factor on the x, y components of the refracted direction
        (``wt = (−eta_ti·wi.x, −eta_ti·wi.y, cos_theta_t)`` in the local frame).

    References
    ----------
    .. [1] M. Born and E. Wolf, *Principles of Optics*, 7th ed., §1.5.2, 1999.
    .. [2] Mitsuba 3, ``fresnel(cos_theta_i, eta)`` in ``include/mitsuba/render/fresnel.h``.

    Examples
    --------
    Into glass at sin θi = 0.6: sin θt = 0.4, the refracted ray goes down:

    >>> F, cos_theta_t, eta_it, eta_ti = fresnel(0.8, 1.5)
    >>> float(F.round(4)), float(cos_theta_t.round(4)), float(eta_it)
    (0.0439, -0.9165, 1.5)
    """
    r_s, r_p, cos_theta_t, eta_it, eta_ti = _dielectric(cos_theta_i, eta)
    return 0.5 * (r_s + r_p), cos_theta_t, eta_it, eta_ti


def fresnel_dielectric(
    cos_theta_i: Any, eta: Any, *, polarized: bool = False
) -> Array | tuple[Array, Array]:
    """Exact Fresnel reflectance of a smooth dielectric interface.

    ``R = (Rs + Rp) / 2`` with ``Rs = r_s²``, ``Rp = r_p²`` as in :func:`fresnel`; ``R = 1``
    beyond the critical angle ``sin θc = η_it`` when light comes from the denser side. The
    transmittance is ``T = 1 − R`` (energy is conserved at the interface).

    Parameters
    ----------
    cos_theta_i : cosine of the incident direction with the outward normal, in [-1, 1];
        negative for light arriving from inside.
    eta : relative index ``n_inside / n_outside`` (> 0), e.g. 1.5 for glass in air.
    polarized : if True return ``(Rs, Rp)``, the reflectances of the s (TE, perpendicular) and
        p (TM, parallel) polarisations, instead of ``R``.

    References
    ----------
    .. [1] M. Born and E. Wolf, *Principles of Optics*, 7th ed., §1.5.2-1.5.4, 1999.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *PBRT*, 4th ed., §9.3.5 ``FrDielectric``, 2023.

    Examples
    --------
    Glass at normal, 60° and grazing incidence; from inside at 60°, beyond the critical angle:

    >>> import numpy as np
    >>> fresnel_dielectric(np.array([1.0, 0.5, 0.0]), 1.5).round(4).tolist()
    [0.04, 0.0892, 1.0]
    >>> float(fresnel_dielectric(-0.5, 1.5))
    1.0
    >>> r_s, r_p = fresnel_dielectric(0.5, 1.5, polarized=True)
    >>> float(r_s.round(4)), float(r_p.round(4))
    (0.1766, 0.0018)
    """
    r_s, r_p, _, _, _ = _dielectric(cos_theta_i, eta)
    return (r_s, r_p) if polarized else 0.5 * (r_s + r_p)


# --------------------------------------------------------------------------- conductors
def fresnel_conductor(
    cos_theta_i: Any, eta: Any, k: Any, *, polarized: bool = False, validate: bool = True
) -> Array | tuple[Array, Array]:
    """Exact Fresnel reflectance of a conductor with complex relative index ``η + iκ``.

    In real arithmetic (Moeller, *Optics*, 1988, as in Mitsuba 3 and PBRT), with
    ``s² = 1 − cos²θ``: ``a² + b² = √((η² − κ² − s²)² + 4η²κ²)``,
    ``a = √((a² + b² + η² − κ² − s²)/2)``,

    ``Rs = (a² + b² + cos²θ − 2a cos θ) / (a² + b² + cos²θ + 2a cos θ)``,
    ``Rp = Rs · ((a² + b²) cos²θ + s⁴ − 2a cos θ s²) / ((a² + b²) cos²θ + s⁴ + 2a cos θ s²)``,

    ``R = (Rs + Rp)/2``, computed as ``Rs · t₃/(t₃ + t₄)`` with ``t₃ ± t₄`` Rp's numerator and
    denominator (one division); the numerators, sums of squares, are kept ≥ 0 against
    cancellation. At normal incidence ``R = ((η−1)² + κ²)/((η+1)² + κ²)``; at grazing
    incidence ``R = 1``; with ``κ = 0`` it equals :func:`fresnel_dielectric` for light from
    outside. The metal is opaque, so the sign of ``cos_theta_i`` is ignored.

    Parameters
    ----------
    cos_theta_i : cosine of the incident direction with the normal, in [-1, 1].
    eta : real part of the relative index (> 0).
    k : extinction coefficient, the imaginary part (≥ 0).
    polarized : if True return ``(Rs, Rp)`` instead of ``R``.
    validate : check the arguments (the default). ``False`` is for callers that checked once
        what they evaluate many times (a model's parameters at construction, cosines clamped
        to [-1, 1]): the checks cost a dozen passes over the cosines.

    References
    ----------
    .. [1] M. Born and E. Wolf, *Principles of Optics*, 7th ed., §14.2, 1999.
    .. [2] K. D. Moeller, *Optics*, University Science Books, 1988.
    .. [3] Mitsuba 3, ``fresnel_conductor`` in ``include/mitsuba/render/fresnel.h``.

    Examples
    --------
    Gold's RGB index (:func:`conductor`), at normal and at grazing incidence:

    >>> import numpy as np
    >>> eta, k = (np.array(v) for v in conductor("Au"))
    >>> fresnel_conductor(1.0, eta, k).round(4).tolist()
    [0.9667, 0.802, 0.3241]
    >>> fresnel_conductor(0.0, eta, k).round(4).tolist()
    [1.0, 1.0, 1.0]
    """
    cos_theta_i, eta, k = asarrays(cos_theta_i, eta, k)
    if validate:
        check_param("eta", eta, 0.0, lo_open=True, hint="real part of the index")
        check_param("k", k, 0.0, hint="extinction coefficient")
        cos_theta_i = _cosine(cos_theta_i)
    xp = namespace(cos_theta_i, eta, k)
    cos_i = xp.abs(cos_theta_i)
    cos2 = cos_i * cos_i
    sin2 = 1 - cos2
    sin4 = sin2 * sin2
    temp = eta * eta - k * k - sin2
    a2_plus_b2 = safe_sqrt(temp * temp + 4 * eta * eta * k * k)
    a = safe_sqrt(0.5 * (a2_plus_b2 + temp))
    term_1 = a2_plus_b2 + cos2
    term_2 = 2 * cos_i * a
    term_3 = a2_plus_b2 * cos2 + sin4
    term_4 = term_2 * sin2
    # term_1 − term_2 = (a − cos θ)² + b² ≥ 0, which cancellation can take below 0 (η = 1,
    # κ = 0: −6e-17); the same for term_3 − term_4 = (a cos θ − s²)² + b² cos²θ.
    zero = xp.zeros_like(term_1)
    rs_numerator = xp.maximum(term_1 - term_2, zero)
    if polarized:
        r_s = safe_div(rs_numerator, term_1 + term_2)
        return r_s, r_s * safe_div(xp.maximum(term_3 - term_4, zero), term_3 + term_4)
    # (Rs + Rp)/2 = Rs·term_3/(term_3 + term_4): one division where the two ratios take two.
    return safe_div(rs_numerator * term_3, (term_1 + term_2) * (term_3 + term_4))


# --------------------------------------------------------------------------- normal incidence
def f0_from_ior(eta: Any) -> Array:
    """Reflectance at normal incidence of a dielectric, ``F0 = ((η − 1)/(η + 1))²``.

    Glass (η = 1.5) gives 0.04, diamond (2.419) 0.172. ``η`` and ``1/η`` give the same F0.

    References
    ----------
    .. [1] M. Born and E. Wolf, *Principles of Optics*, 7th ed., eq. 1.5(24), 1999.

    Examples
    --------
    >>> import numpy as np
    >>> f0_from_ior(np.array([1.5, 2.419, 1 / 1.5])).round(4).tolist()
    [0.04, 0.1723, 0.04]
    """
    (eta,) = asarrays(eta)
    check_param("eta", eta, 0.0, lo_open=True, hint="relative index")
    r = (eta - 1) / (eta + 1)
    return r * r


def f0_from_conductor(eta: Any, k: Any) -> Array:
    """Reflectance at normal incidence of a conductor, ``F0 = ((η−1)² + κ²)/((η+1)² + κ²)``.

    References
    ----------
    .. [1] M. Born and E. Wolf, *Principles of Optics*, 7th ed., eq. 14.2(26), 1999.

    Examples
    --------
    With κ = 0 it is the dielectric's :func:`f0_from_ior`:

    >>> float(f0_from_conductor(1.5, 0.0).round(4)), float(f0_from_conductor(0.2, 3.0).round(4))
    (0.04, 0.9234)
    """
    eta, k = asarrays(eta, k)
    check_param("eta", eta, 0.0, lo_open=True, hint="real part of the index")
    check_param("k", k, 0.0, hint="extinction coefficient")
    k2 = k * k
    return ((eta - 1) ** 2 + k2) / ((eta + 1) ** 2 + k2)


def schlick(cos_theta_i: Any, f0: Any) -> Array:
    """Schlick's approximation ``F ≈ F0 + (1 − F0)(1 − cos θ)⁵``.

    ``f0`` may be channel-valued (e.g. RGB from :func:`f0_from_conductor`); the sign of
    ``cos_theta_i`` is ignored (for light leaving a denser medium, pass the cosine on the
    rarer side, ``cos θt``). It is exact at normal and grazing incidence; for glass (η = 1.5)
    its largest relative error against :func:`fresnel_dielectric` is 23 %, near 56° (Chapman).

    References
    ----------
    .. [1] C. Schlick, "An inexpensive BRDF model for physically-based rendering", *Computer
           Graphics Forum* 13(3):233-246, 1994, eq. 15.
    .. [2] N. Chapman, "Better approximations to the Fresnel reflectance", 2023,
           https://www.forwardscattering.org/post/65

    Examples
    --------
    >>> import numpy as np
    >>> schlick(np.array([1.0, 0.5, 0.0]), 0.04).round(4).tolist()
    [0.04, 0.07, 1.0]
    """
    cos_theta_i, f0 = asarrays(cos_theta_i, f0)
    check_param("f0", f0, 0.0, 1.0, hint="reflectance at normal incidence")
    xp = namespace(cos_theta_i, f0)
    m = 1 - xp.abs(_cosine(cos_theta_i))
    m2 = m * m
    return f0 + (1 - f0) * (m2 * m2 * m)


__all__ = [
    "CONDUCTORS",
    "IOR",
    "conductor",
    "dielectric",
    "f0_from_conductor",
    "f0_from_ior",
    "fresnel",
    "fresnel_conductor",
    "fresnel_dielectric",
    "rgb_from_spectrum",
    "schlick",
]
