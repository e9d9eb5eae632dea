r"""Colorimetry brdfkit needs: the CIE 1931 observer, D65, sRGB's matrices, CIELAB and CIEDE2000.

brdfkit turns spectra into linear sRGB (measured spectral BRDFs, metals' indices, the sun) and
measures how alike two colours look. These are a few tables and formulas; the library that
offers them (colour-science) is a 94 MiB install, so they are restated here, each exactly as
colour-science 0.4 computes it for brdfkit's inputs, and the tests bind every function to
colour-science where it is installed (to ~1e-12 relative).

- The CIE 1931 2° standard observer :math:`\bar x, \bar y, \bar z` at 1 nm over 360–830 nm and
  the CIE standard illuminant D65 at 5 nm over 300–780 nm: CIE 015:2018's values as
  colour-science distributes them (``cie_1931_2deg_d65.npz``, see the data README).
- Tristimulus values by colour-science's "Integration" method (ASTM E308's plain sum):

  .. math::

      X = k \sum_\lambda R(\lambda)\,S(\lambda)\,\bar x(\lambda)\,\Delta\lambda,\qquad
      k = 1 \Big/ \sum_\lambda \bar y(\lambda)\,S(\lambda)\,\Delta\lambda

  (likewise Y, Z; Y = 1 for a perfect reflector), on the observer's 1 nm grid. A spectrum on
  another grid is first aligned to it as colour-science aligns one: interpolated inside its own
  range by Sprague (1880) when evenly spaced, else by a not-a-knot cubic spline, then its end
  values held out to 360 and 830 nm (:func:`align_to_observer`); D65 is interpolated linearly
  and held beyond 780 nm (:func:`d65`).
- The sRGB matrices of IEC 61966-2-1:1999 (:data:`XYZ_TO_LINEAR_SRGB`,
  :data:`LINEAR_SRGB_TO_XYZ`, four decimals as the standard prints them; they are not exact
  inverses of each other) and the Bradford adaptation between white points
  (:func:`bradford_adaptation`).
- CIELAB (CIE 015:2018) and the CIEDE2000 difference (Sharma, Wu & Dalal 2005).

References
----------
.. [1] CIE 015:2018, *Colorimetry*, 4th ed. (the 1931 observer, D65, CIELAB, the integration).
.. [2] IEC 61966-2-1:1999, *Default RGB colour space — sRGB*.
.. [3] G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula: implementation
       notes, supplementary test data, and mathematical observations", Color Res. Appl. 30(1),
       21–30, 2005.
.. [4] W. F. Sprague, "Explanation of a new formula for interpolation", J. Inst. Actuaries 22,
       270–285, 1880.
.. [5] K. M. Lam, "Metamerism and colour constancy", PhD thesis, University of Bradford, 1985
       (the Bradford transform).
.. [6] colour-science 0.4 (``colour.sd_to_XYZ`` "Integration", ``SpectralDistribution.align``,
       ``SpragueInterpolator``, ``XYZ_to_Lab``, ``delta_E_CIE2000``), https://colour.readthedocs.io.
"""

from __future__ import annotations

import functools
from importlib.resources import files

import numpy as np

OBSERVER_TABLE = "cie_1931_2deg_d65.npz"
"""The shipped tables (``wavelengths``, ``xyz_bar``, ``d65_wavelengths``, ``d65``)."""

OBSERVER_RANGE = (360.0, 830.0)
"""The wavelengths (nm) the CIE 1931 2° observer tabulates, every 1 nm."""

XYZ_TO_LINEAR_SRGB = np.array(
    [
        [3.2406, -1.5372, -0.4986],
        [-0.9689, 1.8758, 0.0415],
        [0.0557, -0.2040, 1.0570],
    ]
)
"""CIE XYZ (D65 white, Y = 1) to linear sRGB, IEC 61966-2-1:1999 (rows)."""

LINEAR_SRGB_TO_XYZ = np.array(
    [
        [0.4124, 0.3576, 0.1805],
        [0.2126, 0.7152, 0.0722],
        [0.0193, 0.1192, 0.9505],
    ]
)
"""Linear sRGB to CIE XYZ (D65 white), IEC 61966-2-1:1999 (rows)."""

D65_XY = (0.3127, 0.3290)
"""The chromaticity of D65 as sRGB states it (its white point, the CIELAB white here)."""

E_XY = (1 / 3, 1 / 3)
"""The chromaticity of the equal-energy illuminant E."""

BRADFORD = np.array(
    [
        [0.8951, 0.2664, -0.1614],
        [-0.7502, 1.7135, 0.0367],
        [0.0389, -0.0685, 1.0296],
    ]
)
"""The Bradford cone-response matrix (Lam 1985), XYZ to sharpened RGB (rows)."""

_SPRAGUE_ENDS = np.array(
    [
        [884, -1960, 3033, -2648, 1080, -180],
        [508, -540, 488, -367, 144, -24],
        [-24, 144, -367, 488, -540, 508],
        [-180, 1080, -2648, 3033, -1960, 884],
    ]
)
"""Sprague's coefficients (÷ 209) for the two extra nodes beyond each end of the data."""

_SPRAGUE_POLYNOMIAL = np.array(
    [
        [2, -16, 0, 16, -2, 0],
        [-1, 16, -30, 16, -1, 0],
        [-9, 39, -70, 66, -33, 7],
        [13, -64, 126, -124, 61, -12],
        [-5, 25, -50, 50, -25, 5],
    ]
)
"""Sprague's quintic (÷ 24): the coefficients of X¹…X⁵ from the six nodes around an interval."""


@functools.cache
def _tables() -> dict[str, np.ndarray]:
    """The shipped tables, read once and read-only (every caller shares them)."""
    with np.load(str(files("brdfkit.data") / OBSERVER_TABLE)) as data:
        tables = {key: data[key] for key in data.files}
    for table in tables.values():
        table.flags.writeable = False
    return tables


def observer() -> tuple[np.ndarray, np.ndarray]:
    r"""The CIE 1931 2° standard observer: wavelengths ``(471,)`` nm (360–830 every 1 nm) and
    :math:`(\bar x, \bar y, \bar z)` ``(471, 3)`` (CIE 015:2018).

    Examples
    --------
    >>> wavelengths, xyz_bar = observer()
    >>> float(wavelengths[xyz_bar[:, 1].argmax()]), float(xyz_bar[:, 1].max())  # V(λ) peak
    (555.0, 1.0)
    """
    tables = _tables()
    return tables["wavelengths"], tables["xyz_bar"]


def observer_at(wavelengths: np.ndarray) -> np.ndarray:
    r"""The observer's :math:`(\bar x, \bar y, \bar z)` ``(n, 3)`` at whole-nanometre
    ``wavelengths`` ``(n,)``, 0 outside 360–830 nm (the observer sees nothing there).

    Examples
    --------
    >>> observer_at([320.0, 555.0]).round(4).tolist()
    [[0.0, 0.0, 0.0], [0.5121, 1.0, 0.0057]]
    """
    grid, xyz_bar = observer()
    wavelengths = np.rint(np.asarray(wavelengths, dtype=np.float64))
    inside = (wavelengths >= grid[0]) & (wavelengths <= grid[-1])
    index = np.clip(wavelengths - grid[0], 0, len(grid) - 1).astype(int)
    return np.where(inside[:, None], xyz_bar[index], 0.0)


def d65() -> np.ndarray:
    """The CIE D65 spectral power on the observer's grid ``(471,)``, aligned as colour-science
    aligns it: linear between its 5 nm values (300–780 nm), its 780 nm value held beyond.

    Examples
    --------
    >>> float(d65()[560 - 360])  # D65 is 100 at 560 nm
    100.0
    """
    tables = _tables()
    return np.interp(observer()[0], tables["d65_wavelengths"], tables["d65"])


def _sprague(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Sprague's quintic through evenly spaced ``(x, y)`` (``y``: ``(n, ...)``, n ≥ 6) at
    ``at`` (inside ``x``), as colour-science's ``SpragueInterpolator`` evaluates it."""
    h = x[1] - x[0]
    xp = np.concatenate([[x[0] - 2 * h, x[0] - h], x, [x[-1] + h, x[-1] + 2 * h]])
    ends = np.stack([y[:6], y[:6], y[-6:], y[-6:]])
    extra = np.einsum("kj,kj...->k...", _SPRAGUE_ENDS, ends) / 209
    yp = np.concatenate([extra[:2], y, extra[2:]])
    i = np.searchsorted(xp, at) - 1
    t = (at - xp[i]) / (xp[i + 1] - xp[i])
    nodes = np.stack([yp[i + offset] for offset in range(-2, 4)])  # i - 2 wraps, as there
    a = np.einsum("pj,ji...->pi...", _SPRAGUE_POLYNOMIAL, nodes) / 24
    powers = t[None, :] ** np.arange(1, 6)[:, None]
    return yp[i] + np.einsum("pi...,pi->i...", a, powers)


def align_to_observer(wavelengths: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Spectral values ``(n, ...)`` at whole-nanometre ``wavelengths`` ``(n,)`` on the
    observer's 1 nm grid ``(471, ...)``, as colour-science's ``SpectralDistribution.align``
    puts them there: inside the data's range (clipped to 360–830 nm) Sprague's quintic when
    the wavelengths are evenly spaced, else a not-a-knot cubic spline; beyond it the first and
    last of those values held.

    ``values`` columns are independent spectra (an identity matrix gives the alignment's
    matrix). Needs n ≥ 6 when evenly spaced, n ≥ 4 otherwise, with the range overlapping the
    observer's.

    Examples
    --------
    >>> import numpy as np
    >>> wl = np.arange(400.0, 701.0, 10.0)
    >>> aligned = align_to_observer(wl, np.ones(wl.size))
    >>> aligned.shape, bool(np.allclose(aligned, 1.0))
    ((471,), True)
    """
    grid = observer()[0]
    wavelengths = np.asarray(wavelengths, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    start = max(grid[0], wavelengths[0])
    end = min(grid[-1], wavelengths[-1])
    inside = grid[(grid >= start) & (grid <= end)]
    steps = np.abs(np.diff(wavelengths))
    if np.all(steps == steps[0]):
        interpolated = _sprague(wavelengths, values, inside)
    else:
        from scipy.interpolate import make_interp_spline  # only for unevenly spaced spectra

        interpolated = make_interp_spline(wavelengths, values, k=3, axis=0)(inside)
    below = np.count_nonzero(grid < start)
    above = np.count_nonzero(grid > end)
    return np.concatenate(
        [
            np.repeat(interpolated[:1], below, axis=0),
            interpolated,
            np.repeat(interpolated[-1:], above, axis=0),
        ]
    )


def tristimulus(values: np.ndarray, illuminant: np.ndarray | None = None) -> np.ndarray:
    """CIE XYZ ``(..., 3)`` of spectra ``(471, ...)`` on the observer's grid under
    ``illuminant`` ``(471,)`` (default E, all ones), normalised so that Y = 1 for a perfect
    reflector: colour-science's ``sd_to_XYZ(..., method="Integration") / 100``.

    Examples
    --------
    >>> import numpy as np
    >>> tristimulus(np.ones(471), d65()).round(4).tolist()  # the D65 white, Y = 1
    [0.9505, 1.0, 1.0888]
    """
    xyz_bar = observer()[1]
    weight = np.ones(len(xyz_bar)) if illuminant is None else np.asarray(illuminant)
    k = 1 / np.sum(xyz_bar[:, 1] * weight)
    spectra = np.moveaxis(np.asarray(values, dtype=np.float64), 0, -1)
    return k * ((spectra * weight) @ xyz_bar)


def xy_to_xyz(xy: tuple[float, float]) -> np.ndarray:
    """CIE XYZ with Y = 1 of a chromaticity ``(x, y)``: ``(x/y, 1, (1 - x - y)/y)``."""
    x, y = xy
    return np.array([x / y, 1.0, (1 - (x + y)) / y])


def bradford_adaptation(
    source_xy: tuple[float, float], target_xy: tuple[float, float]
) -> np.ndarray:
    r"""The von Kries matrix in Bradford's cone space taking XYZ seen under the white
    ``source_xy`` to XYZ under ``target_xy``: :math:`M_B^{-1}\,\mathrm{diag}(M_B W_t / M_B W_s)
    \,M_B` (Lam 1985).

    Examples
    --------
    >>> (bradford_adaptation(E_XY, D65_XY) @ xy_to_xyz(E_XY)).round(4).tolist()  # E's white → D65's
    [0.9505, 1.0, 1.0891]
    """
    cone_source = BRADFORD @ xy_to_xyz(source_xy)
    cone_target = BRADFORD @ xy_to_xyz(target_xy)
    return np.linalg.inv(BRADFORD) @ np.diag(cone_target / cone_source) @ BRADFORD


def xyz_e_to_linear_srgb() -> np.ndarray:
    """XYZ under the equal-energy illuminant E to linear sRGB, Bradford-adapted to sRGB's D65
    so that XYZ = (1, 1, 1) is RGB ≈ (1, 1, 1): :data:`XYZ_TO_LINEAR_SRGB` ·
    ``bradford_adaptation(E_XY, D65_XY)``.

    Examples
    --------
    >>> import numpy as np
    >>> (xyz_e_to_linear_srgb() @ np.ones(3)).round(3).tolist()
    [1.0, 1.0, 1.0]
    """
    return XYZ_TO_LINEAR_SRGB @ bradford_adaptation(E_XY, D65_XY)


def xyz_to_lab(xyz: np.ndarray, white_xy: tuple[float, float] = D65_XY) -> np.ndarray:
    r"""CIELAB ``(..., 3)`` of XYZ ``(..., 3)`` (Y = 1 for the white) under the white
    ``white_xy``: :math:`L^* = 116 f(Y/Y_n) - 16`, :math:`a^* = 500 (f(X/X_n) - f(Y/Y_n))`,
    :math:`b^* = 200 (f(Y/Y_n) - f(Z/Z_n))` with :math:`f(t) = t^{1/3}` above
    :math:`(24/116)^3`, else :math:`(841/108)\,t + 16/116` (CIE 015:2018).

    Examples
    --------
    >>> xyz_to_lab(xy_to_xyz(D65_XY)).round(12).tolist()  # the white
    [100.0, 0.0, 0.0]
    """
    ratio = np.asarray(xyz, dtype=np.float64) / xy_to_xyz(white_xy)
    f = np.where(ratio > (24 / 116) ** 3, np.cbrt(ratio), (841 / 108) * ratio + 16 / 116)
    fx, fy, fz = f[..., 0], f[..., 1], f[..., 2]
    return np.stack([116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)], axis=-1)


def _hue_degrees(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """h' in [0, 360) degrees, 0 where a' = b = 0."""
    return np.where((b == 0) & (a == 0), 0.0, np.degrees(np.arctan2(b, a)) % 360)


def ciede2000(lab_1: np.ndarray, lab_2: np.ndarray) -> np.ndarray:
    r"""The CIEDE2000 colour difference :math:`\Delta E_{00}` between CIELAB colours
    ``(..., 3)`` (Sharma, Wu & Dalal 2005, eqs. 1–17; :math:`k_L = k_C = k_H = 1`):

    .. math::

        \Delta E_{00} = \sqrt{\Big(\frac{\Delta L'}{S_L}\Big)^2 + \Big(\frac{\Delta C'}{S_C}\Big)^2
        + \Big(\frac{\Delta H'}{S_H}\Big)^2 + R_T \frac{\Delta C'}{S_C}\frac{\Delta H'}{S_H}}

    with :math:`a' = (1 + G)\,a^*`, :math:`G = \tfrac12\big(1 - \sqrt{\bar C^7/(\bar C^7 +
    25^7)}\big)`, :math:`\Delta H' = 2\sqrt{C'_1 C'_2}\sin(\Delta h'/2)`, :math:`S_L = 1 +
    0.015(\bar L' - 50)^2/\sqrt{20 + (\bar L' - 50)^2}`, :math:`S_C = 1 + 0.045\,\bar C'`,
    :math:`S_H = 1 + 0.015\,\bar C' T`, :math:`T = 1 - 0.17\cos(\bar h' - 30°) + 0.24\cos(2\bar h')
    + 0.32\cos(3\bar h' + 6°) - 0.20\cos(4\bar h' - 63°)` and the rotation :math:`R_T =
    -\sin(2\Delta\theta)\,R_C`, :math:`\Delta\theta = 30°\exp(-((\bar h' - 275°)/25°)^2)`,
    :math:`R_C = 2\sqrt{\bar C'^7/(\bar C'^7 + 25^7)}`. Symmetric in its arguments; about 1 is
    a just-noticeable difference. Agrees with Sharma et al.'s 34 test pairs to their four
    decimals.

    Examples
    --------
    >>> import numpy as np
    >>> blue, bluer = np.array([50.0, 2.6772, -79.7751]), np.array([50.0, 0.0, -82.7485])
    >>> float(ciede2000(blue, bluer).round(4))  # Sharma et al.'s first pair
    2.0425
    """
    lab_1 = np.asarray(lab_1, dtype=np.float64)
    lab_2 = np.asarray(lab_2, dtype=np.float64)
    L1, a1, b1 = lab_1[..., 0], lab_1[..., 1], lab_1[..., 2]
    L2, a2, b2 = lab_2[..., 0], lab_2[..., 1], lab_2[..., 2]

    c_bar_7 = ((np.hypot(a1, b1) + np.hypot(a2, b2)) / 2) ** 7
    G = 0.5 * (1 - np.sqrt(c_bar_7 / (c_bar_7 + 25**7)))
    a1p, a2p = (1 + G) * a1, (1 + G) * a2
    C1p, C2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1p, h2p = _hue_degrees(a1p, b1), _hue_degrees(a2p, b2)

    chroma_product = C1p * C2p
    dhp = h2p - h1p
    dhp = np.select(
        [chroma_product == 0, np.fabs(dhp) <= 180, dhp > 180, dhp < -180],
        [0, dhp, dhp - 360, dhp + 360],
    )
    dLp = L2 - L1
    dCp = C2p - C1p
    dHp = 2 * np.sqrt(chroma_product) * np.sin(np.deg2rad(dhp / 2))

    L_bar = (L1 + L2) / 2
    C_bar = (C1p + C2p) / 2
    hue_gap, hue_sum = np.fabs(h1p - h2p), h1p + h2p
    h_bar = np.select(
        [
            chroma_product == 0,
            hue_gap <= 180,
            (hue_gap > 180) & (hue_sum < 360),
            (hue_gap > 180) & (hue_sum >= 360),
        ],
        [hue_sum, hue_sum / 2, (hue_sum + 360) / 2, (hue_sum - 360) / 2],
    )
    T = (
        1
        - 0.17 * np.cos(np.deg2rad(h_bar - 30))
        + 0.24 * np.cos(np.deg2rad(2 * h_bar))
        + 0.32 * np.cos(np.deg2rad(3 * h_bar + 6))
        - 0.20 * np.cos(np.deg2rad(4 * h_bar - 63))
    )
    d_theta = 30 * np.exp(-(((h_bar - 275) / 25) ** 2))
    C_bar_7 = C_bar**7
    R_C = 2 * np.sqrt(C_bar_7 / (C_bar_7 + 25**7))
    L_50 = (L_bar - 50) ** 2
    S_L = 1 + 0.015 * L_50 / np.sqrt(20 + L_50)
    S_C = 1 + 0.045 * C_bar
    S_H = 1 + 0.015 * C_bar * T
    R_T = -np.sin(np.deg2rad(2 * d_theta)) * R_C
    lightness, chroma, hue = dLp / S_L, dCp / S_C, dHp / S_H
    return np.sqrt(lightness**2 + chroma**2 + hue**2 + R_T * chroma * hue)


__all__ = [
    "BRADFORD",
    "D65_XY",
    "E_XY",
    "LINEAR_SRGB_TO_XYZ",
    "OBSERVER_RANGE",
    "OBSERVER_TABLE",
    "XYZ_TO_LINEAR_SRGB",
    "align_to_observer",
    "bradford_adaptation",
    "ciede2000",
    "d65",
    "observer",
    "observer_at",
    "tristimulus",
    "xy_to_xyz",
    "xyz_e_to_linear_srgb",
    "xyz_to_lab",
]
