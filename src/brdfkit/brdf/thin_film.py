r"""Thin-film iridescence over GGX microfacets (Belcour & Barla 2017), spectral and RGB.

A film of thickness d and index η2 coats a base of complex index η3 + iκ3 (a conductor, or a
dielectric with κ3 = 0), in air (η1 = 1). Each facet reflects with the Airy reflectance of the
two interfaces, per polarisation (s, p), averaged:

.. math::
    R = \frac{r_{12}^2 + \rho_{23}^2 + 2 r_{12}\rho_{23}\cos\Phi}
             {1 + r_{12}^2\rho_{23}^2 + 2 r_{12}\rho_{23}\cos\Phi},\qquad
    \Phi = \frac{2\pi}{\lambda}\,2\eta_2 d\cos\theta_2 + \varphi_{23},

with :math:`r_{12}` the (real, signed) amplitude of the air–film interface and
:math:`r_{23} = \rho_{23}e^{i\varphi_{23}}` the complex amplitude of the film–base interface
(Born & Wolf; :func:`airy_reflectance`, exact, in real arithmetic). In RGB,
Belcour & Barla write R as the Fourier series
:math:`R = C_0 + 2\sum_{m\ge1} C_m\cos(m\Phi)`, :math:`C_0 = R_{12} + R_s`,
:math:`C_m = (R_s - T_{121})\sqrt{R_{12}R_{23}}^{\,m}`,
:math:`R_s = T_{121}^2R_{23}/(1 - R_{12}R_{23})`, and integrate each term against the CIE
colour-matching functions in closed form (Gaussian fits of their Fourier transforms), which
removes the spectral aliasing of a few-wavelength rendering (:func:`belcour_barla_xyz`).

References
----------
.. [1] L. Belcour, P. Barla, "A practical extension to microfacet theory for the modeling of
       varying iridescence", ACM TOG 36(4) (SIGGRAPH), 2017, and its supplemental code.
.. [2] M. Born, E. Wolf, *Principles of Optics*, 7th ed., ch. 1 and 14, 1999.
.. [3] The Khronos Group, ``KHR_materials_iridescence`` (glTF 2.0), 2022 (the sensitivity
       fits in nanometres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, clamp, constant, namespace, safe_div, safe_sqrt, to_numpy
from brdfkit.brdf.base import BRDF, ROUGHNESS, register
from brdfkit.brdf.microfacet import EXTINCTION, GGX, IOR
from brdfkit.brdf.microfacet_reflection import MicrofacetReflection
from brdfkit.data import colorimetry
from brdfkit.errors import ParameterError
from brdfkit.params import Domain, channel_count, param

THICKNESS = Domain(0.0, 10_000.0, hint="film thickness in nanometres")
"""The film thickness d: [0, 10⁴] nm (beyond a few µm the colours wash out to the mean)."""

FILM_IOR = Domain(1.0, 5.0, hint="film index η2 (≥ 1, the air above)")
"""The film's index η2: [1, 5] (no total internal reflection in the film)."""

WAVELENGTH = Domain(200.0, 3000.0, hint="wavelength in nanometres")
"""Wavelengths of the spectral mode: [200, 3000] nm."""

ORDERS = 3
"""Fourier terms m = 1 … 3 of the RGB series, as Belcour & Barla."""


# --------------------------------------------------------------------------- film optics
def film_amplitudes(
    cos_theta_1: Array, eta_film: Array, eta_base: Array, k_base: Array
) -> tuple[tuple[tuple[Array, Array, Array], tuple[Array, Array, Array]], Array]:
    r"""The amplitudes of a film's two interfaces, per polarisation, in real arithmetic.

    For light from air (η1 = 1) at cosine ``cos_theta_1`` with :math:`S = \sin^2\theta_1`:
    :math:`q_2 = \eta_2\cos\theta_2 = \sqrt{\eta_2^2 - S}` (real: η2 ≥ 1) and
    :math:`q_3 = n_3\cos\theta_3 = \sqrt{n_3^2 - S} = u + iv` for :math:`n_3 = \eta_3 + i\kappa_3`;
    :math:`r_{12}^s = (\cos\theta_1 - q_2)/(\cos\theta_1 + q_2)`,
    :math:`r_{12}^p = (\eta_2^2\cos\theta_1 - q_2)/(\eta_2^2\cos\theta_1 + q_2)`,
    :math:`r_{23}^s = (q_2 - q_3)/(q_2 + q_3)`,
    :math:`r_{23}^p = (n_3^2q_2 - \eta_2^2q_3)/(n_3^2q_2 + \eta_2^2q_3)`
    (the same sign convention at both interfaces).

    Returns
    -------
    ``(((r12_s, R23_s, phi23_s), (r12_p, R23_p, phi23_p)), q2)``: the signed real r12, the
    reflectance :math:`|r_{23}|^2` and phase :math:`\arg r_{23}` per polarisation, and
    :math:`q_2` (the optical path difference is :math:`2 q_2 d`).
    """
    xp = namespace(cos_theta_1, eta_film, eta_base, k_base)
    c1 = clamp(cos_theta_1, 0.0, 1.0)
    s = 1 - c1 * c1
    n2_sq = eta_film * eta_film
    q2 = safe_sqrt(n2_sq - s)
    r12_s = safe_div(c1 - q2, c1 + q2)
    r12_p = safe_div(n2_sq * c1 - q2, n2_sq * c1 + q2)
    re_n3_sq = eta_base * eta_base - k_base * k_base
    im_n3_sq = 2 * eta_base * k_base
    a = re_n3_sq - s
    modulus = xp.sqrt(a * a + im_n3_sq * im_n3_sq)
    u, v = safe_sqrt(0.5 * (modulus + a)), safe_sqrt(0.5 * (modulus - a))

    def ratio(nr: Array, ni: Array, dr: Array, di: Array) -> tuple[Array, Array]:
        return safe_div(nr * nr + ni * ni, dr * dr + di * di), xp.atan2(ni, nr) - xp.atan2(di, dr)

    r23_s = ratio(q2 - u, -v + 0 * q2, q2 + u, v + 0 * q2)
    r23_p = ratio(
        re_n3_sq * q2 - n2_sq * u,
        im_n3_sq * q2 - n2_sq * v,
        re_n3_sq * q2 + n2_sq * u,
        im_n3_sq * q2 + n2_sq * v,
    )
    return ((r12_s, *r23_s), (r12_p, *r23_p)), q2


def airy_reflectance(
    cos_theta_1: Array,
    wavelength: Array,
    thickness: Array,
    eta_film: Array,
    eta_base: Array,
    k_base: Array,
) -> Array:
    """The exact Airy reflectance of a film on a base (the module's formula), unpolarised.

    Every argument broadcasts (``cos_theta_1`` ``(..., 1)`` against per-wavelength ``(N,)``
    parameters gives ``(..., N)``); wavelengths and thickness in the same unit (nm).
    """
    xp = namespace(cos_theta_1, wavelength, thickness, eta_film, eta_base, k_base)
    polarisations, q2 = film_amplitudes(cos_theta_1, eta_film, eta_base, k_base)
    delta = (4 * math.pi) * q2 * thickness / wavelength
    total = 0
    for r12, r23_sq, phi23 in polarisations:
        cross = 2 * r12 * xp.sqrt(r23_sq) * xp.cos(delta + phi23)
        r12_sq = r12 * r12
        total = total + (r12_sq + r23_sq + cross) / (1 + r12_sq * r23_sq + cross)
    return 0.5 * total


def _envelopes(opd: Array) -> tuple[Array, Array, Array]:
    r"""What :func:`_sensitivity` at optical path difference ``opd`` does not owe to its
    shift: the phase :math:`2\pi\cdot 10^{-9}\,\text{opd}` and the Gaussian envelopes
    :math:`e^{-v\,\text{phase}^2}` of the three fits ``(..., 3)`` and of X's second lobe
    ``(..., 1)``; both polarisations of a Fourier order share them."""
    xp = namespace(opd)
    phase = (2 * math.pi * 1e-9) * opd
    var = param([4.3278e09, 9.3046e09, 6.6121e09], opd)
    return phase, xp.exp(-var * phase * phase), xp.exp(-4.5282e09 * phase * phase)


def _sensitivity(
    opd: Array, shift: Array, envelopes: tuple[Array, Array, Array] | None = None
) -> Array:
    r"""The Fourier transform of the CIE 1931 colour-matching functions (Gaussian fits,
    normalised so that the m = 0 term is XYZ ≈ (1, 1, 1) of a white reflector under the
    equal-energy illuminant) at optical path difference ``opd`` (nm), shifted by ``shift``;
    ``(..., 1)`` → ``(..., 3)``. ``envelopes``: :func:`_envelopes` of ``opd``, where the
    caller has them already (the same values).

    References
    ----------
    .. [1] L. Belcour, P. Barla, ACM TOG 36(4), 2017, and its supplemental code
           (``evalSensitivity``); KHR_materials_iridescence for the nanometre form.
    """
    xp = namespace(opd, shift)
    phase, gaussian, gaussian_x = _envelopes(opd) if envelopes is None else envelopes
    val = param([5.4856e-13, 4.4201e-13, 5.2481e-13], opd)
    pos = param([1.6810e06, 1.7953e06, 2.2084e06], opd)
    var = param([4.3278e09, 9.3046e09, 6.6121e09], opd)
    xyz = val * xp.sqrt(2 * math.pi * var) * xp.cos(pos * phase + shift)
    xyz = xyz * gaussian
    extra = 9.7470e-14 * math.sqrt(2 * math.pi * 4.5282e09)
    extra = extra * xp.cos(2.2399e06 * phase + shift) * gaussian_x
    x_only = param([1.0, 0.0, 0.0], opd)
    return (xyz + x_only * extra) / 1.0685e-7


_WHITE = tuple(float(v) for v in _sensitivity(np.zeros(1), np.zeros(1)))
""":func:`_sensitivity` at zero path difference and shift (the m = 0 term, the CMFs'
integrals): cos 0 = e⁰ = 1 exactly, so these are the very floats it gives there."""


def belcour_barla_xyz(
    cos_theta_1: Array,
    thickness: Array,
    eta_film: Array,
    eta_base: Array,
    k_base: Array,
    orders: int = ORDERS,
) -> Array:
    r"""CIE XYZ (equal-energy illuminant, Y = 1 for a white reflector) of the Airy reflectance,
    by Belcour & Barla's spectral integration in Fourier space (module docstring), with
    ``orders`` terms m ≥ 1; ``(..., 1)`` arguments → ``(..., 3)``. The base index is the same
    at every wavelength. The m = 0 term's sensitivity is a constant (:data:`_WHITE`) and each
    order's Gaussian envelopes are computed once for both polarisations (they do not depend
    on the phase shift): the same floats as evaluating :func:`_sensitivity` afresh."""
    xp = namespace(cos_theta_1, thickness, eta_film, eta_base, k_base)
    polarisations, q2 = film_amplitudes(cos_theta_1, eta_film, eta_base, k_base)
    opd = 2 * q2 * thickness
    white = param(_WHITE, opd)
    envelopes = [_envelopes(m * opd) for m in range(1, orders + 1)]
    total = 0
    for r12, r23_sq, phi23 in polarisations:
        r12_sq = r12 * r12
        t121 = 1 - r12_sq
        r123_sq = r12_sq * r23_sq
        rs = t121 * t121 * r23_sq / (1 - r123_sq)
        phi12 = xp.where(r12 < 0, constant(math.pi, r12), constant(0, r12))  # r12 is real
        phi2 = (math.pi - phi12) + phi23
        xyz = (r12_sq + rs) * white
        cm = rs - t121
        r123 = safe_sqrt(r123_sq)
        for m in range(1, orders + 1):
            cm = cm * r123
            xyz = xyz + cm * 2 * _sensitivity(m * opd, m * phi2, envelopes[m - 1])
        total = total + 0.5 * xyz
    return total


_XYZ_TO_LINEAR_SRGB = tuple(tuple(map(float, row)) for row in colorimetry.xyz_e_to_linear_srgb())
""":func:`xyz_to_linear_srgb`'s matrix (rows, Python floats for the kernels' constants)."""


def xyz_to_linear_srgb() -> tuple[tuple[float, ...], ...]:
    """The 3×3 matrix from XYZ under the equal-energy illuminant E to linear sRGB (D65),
    Bradford-adapted so that a white reflector (XYZ = (1, 1, 1)) is RGB (1, 1, 1), as rows:
    :func:`brdfkit.data.colorimetry.xyz_e_to_linear_srgb` (the one source of sRGB's matrix;
    ``tests/brdf/test_thin_film.py`` compares it with colour-science's ``XYZ_to_RGB(np.eye(3),
    "sRGB", illuminant=E, chromatic_adaptation_transform="Bradford").T``)."""
    return _XYZ_TO_LINEAR_SRGB


# --------------------------------------------------------------------------- the Fresnel factor
@dataclass(frozen=True, eq=False)
class ThinFilmFresnel:
    """The Fresnel factor of a film-coated facet, called like
    :class:`~brdfkit.brdf.microfacet.FresnelTerm`: ``(..., 1)`` cosines → ``(..., C)``.

    Spectral (``wavelengths`` given: the exact :func:`airy_reflectance` per wavelength) or RGB
    (``wavelengths=None``: :func:`belcour_barla_xyz` to linear sRGB, clamped to [0, 1]).
    """

    thickness: Any
    eta_film: Any
    eta_base: Any
    k_base: Any
    wavelengths: Any = None
    kind: ClassVar[str] = "thin_film"

    @property
    def channels(self) -> int:
        if self.wavelengths is None:
            return 3
        return channel_count(
            self.wavelengths, self.eta_base, self.k_base, names=("wavelengths", "eta", "k")
        )

    def __call__(self, cos_theta: Array) -> Array:
        xp = namespace(cos_theta)
        cos_theta = xp.abs(clamp(cos_theta, -1.0, 1.0))
        args = [param(v, cos_theta) for v in (self.eta_film, self.eta_base, self.k_base)]
        thickness = param(self.thickness, cos_theta)
        if self.wavelengths is not None:
            return airy_reflectance(cos_theta, param(self.wavelengths, cos_theta), thickness, *args)
        xyz = belcour_barla_xyz(cos_theta, thickness, *args)
        rows = [param(row, cos_theta) for row in xyz_to_linear_srgb()]
        rgb = xp.stack([xp.sum(row * xyz, axis=-1) for row in rows], axis=-1)
        return clamp(rgb, 0.0, 1.0) + constant(0, rgb)


@register("thin_film")
@dataclass(frozen=True, eq=False)
class ThinFilm(MicrofacetReflection):
    r"""A GGX microfacet surface coated by a thin film (Belcour & Barla 2017): iridescence.

    .. math::
        f_r = \frac{D(\omega_h)\,G_2(\omega_i,\omega_o,\omega_h)\,
              R_{film}(\omega_i\cdot\omega_h)}{4\cos\theta_i\cos\theta_o},

    GGX D with height-correlated Smith G2 (as :class:`~brdfkit.brdf.RoughConductor`) and the
    film's Airy reflectance :math:`R_{film}` in place of the Fresnel factor (module
    docstring): the exact :func:`airy_reflectance` at each of ``wavelengths`` (spectral
    mode, one channel per wavelength), or, with ``wavelengths=None`` (RGB mode), Belcour &
    Barla's closed-form integration of it against the CIE 1931 observer (first three Fourier
    terms), in linear sRGB.

    **Reciprocal**: yes (R depends on ωi·ωh = ωo·ωh). **Energy-conserving**: yes: a
    non-absorbing film on a passive base reflects R ≤ 1 (RGB clamped to [0, 1]) and the
    microfacet lobe has albedo ≤ 1 for F ≤ 1.

    Parameters
    ----------
    alpha : GGX roughness in [10⁻⁴, 10].
    thickness : film thickness d in nm, [0, 10⁴] (0: no film).
    film_eta : film index η2 in [1, 5].
    eta, k : the base's index η3 + iκ3 (κ3 = 0: a dielectric base), per wavelength in
        spectral mode; scalars in RGB mode.
    wavelengths : nm, [200, 3000], for spectral mode; ``None`` (default) for RGB.

    References
    ----------
    .. [1] L. Belcour, P. Barla, ACM TOG 36(4), 2017.
    .. [2] E. Heitz, JCGT 3(2), 2014 (height-correlated Smith masking).

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import ThinFilm
    >>> f = ThinFilm(alpha=0.3, thickness=300.0)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0244, 0.0091, 0.0068])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    alpha: Any = 0.1
    thickness: Any = 400.0
    film_eta: Any = 1.33
    eta: Any = 1.5
    k: Any = 0.0
    wavelengths: Any = None
    masking: str = "smith_correlated"
    sample_visible: bool = True
    domains: ClassVar[dict[str, Domain]] = {
        "alpha": ROUGHNESS,
        "thickness": THICKNESS,
        "film_eta": FILM_IOR,
        "eta": IOR,
        "k": EXTINCTION,
        "wavelengths": WAVELENGTH,
    }

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("thickness", "film_eta"):
            if np.ndim(to_numpy(getattr(self, name))) > 0 and np.size(getattr(self, name)) > 1:
                raise ParameterError(
                    f"{name} must be a scalar (the film is the same at every wavelength); got "
                    f"{getattr(self, name)!r:.60}"
                )
        if self.wavelengths is None:
            for name in ("eta", "k"):
                if np.size(to_numpy(getattr(self, name))) > 1:
                    raise ParameterError(
                        f"{name} must be a scalar in RGB mode (wavelengths=None); got "
                        f"{getattr(self, name)!r:.60}; give wavelengths for a dispersive base"
                    )
        fresnel = ThinFilmFresnel(self.thickness, self.film_eta, self.eta, self.k, self.wavelengths)
        channel_count(
            self.alpha, np.zeros(fresnel.channels), names=("alpha", "the film's reflectance")
        )
        self._setup(GGX(self.alpha), fresnel, self.sample_visible)

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(),
            cls(alpha=0.3, thickness=250.0, film_eta=1.8, eta=0.2, k=3.0),
            cls(alpha=0.05, thickness=0.0),
            cls(alpha=0.2, thickness=600.0, wavelengths=[450.0, 550.0, 650.0], eta=[1.5, 1.4, 1.3]),
        ]


__all__ = [
    "FILM_IOR",
    "ORDERS",
    "THICKNESS",
    "WAVELENGTH",
    "ThinFilm",
    "ThinFilmFresnel",
    "airy_reflectance",
    "belcour_barla_xyz",
    "film_amplitudes",
    "xyz_to_linear_srgb",
]
