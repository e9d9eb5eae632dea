r"""Cornell gonioreflectometer files (``.brdf``, as shipped with pbrt-v2).

Text format: ``#`` comment lines; the number of wavelengths n; n wavelengths in nm; then one
row per measurement, :math:`\theta_i\ \varphi_i\ \theta_s\ \varphi_s` (radians; i the light,
s the scattered/viewing direction) followed by n spectral BRDF values (sr⁻¹). The spectra
are converted to linear sRGB through the CIE 1931 2° observer under D65
(:func:`~brdfkit.measured.tabulated.spectrum_to_rgb_matrix`, colour-science); saturated colours
outside the sRGB gamut (a negative channel) are clipped to 0 in that channel.

:func:`read_cornell` returns a :class:`~brdfkit.measured.tabulated.TabulatedBRDF` resampled on
an isotropic half/difference grid by scattered interpolation (Delaunay-linear inside the
samples' hull, nearest outside; :meth:`TabulatedBRDF.from_samples`), which keeps the raw
measurements in ``.samples``: fits use those directly.

References
----------
.. [1] Cornell University Program of Computer Graphics, reflectance data
       (https://www.graphics.cornell.edu/online/measurements/reflectance/); S. C. Foo,
       "A gonioreflectometer for measuring the bidirectional reflectance of material for use
       in illumination computation", M.S. thesis, Cornell, 1997.
.. [2] M. Pharr, G. Humphreys, *Physically Based Rendering*, 2nd ed., §8.6 (the
       ``measured`` material that reads these files).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from brdfkit.geometry import spherical_to_cartesian
from brdfkit.measured.tabulated import MeasuredSamples, TabulatedBRDF, spectrum_to_rgb_matrix


def read_cornell_samples(path: str | os.PathLike) -> MeasuredSamples:
    """The measurements of a Cornell ``.brdf`` file, as linear-sRGB :class:`MeasuredSamples`.

    ``wi`` comes from (θi, φi), ``wo`` from (θs, φs); ``spectral`` and ``wavelengths`` keep the
    original spectra.

    Raises
    ------
    ValueError
        Naming the file, when it holds no numbers, a bad wavelength count, or rows that are not
        4 angles + n values.

    References
    ----------
    .. [1] M. Pharr, G. Humphreys, *Physically Based Rendering*, 2nd ed., §8.6.
    """
    path = Path(path)
    lines = [line.split("#", 1)[0] for line in path.read_text().splitlines()]
    try:
        numbers = np.array(" ".join(lines).split(), dtype=np.float64)
    except ValueError as error:
        raise ValueError(f"Cornell file {str(path)!r} holds a non-number: {error}") from None
    if numbers.size == 0 or numbers[0] != int(numbers[0]) or numbers[0] < 2:
        first = numbers[0] if numbers.size else None
        raise ValueError(
            f"Cornell file {str(path)!r} must start with the wavelength count (an integer >= 2); "
            f"got {first}"
        )
    n = int(numbers[0])
    wavelengths, rows = numbers[1 : 1 + n], numbers[1 + n :]
    if wavelengths.size != n or rows.size == 0 or rows.size % (4 + n):
        raise ValueError(
            f"Cornell file {str(path)!r}: after {n} wavelengths expected rows of 4 angles + {n} "
            f"values; got {rows.size} numbers"
        )
    rows = rows.reshape(-1, 4 + n)
    spectral = rows[:, 4:]
    wi = spherical_to_cartesian(rows[:, 0], rows[:, 1])
    wo = spherical_to_cartesian(rows[:, 2], rows[:, 3])
    # Saturated spectra fall outside the sRGB gamut (a negative channel); clip them to it.
    rgb = np.maximum(spectral @ spectrum_to_rgb_matrix(wavelengths), 0.0)
    return MeasuredSamples(wi, wo, rgb, spectral, wavelengths, name=path.name)


def read_cornell(
    path: str | os.PathLike,
    shape: tuple[int, int, int] = (32, 32, 32),
    *,
    method: str = "linear",
    interpolation: str = "linear",
) -> TabulatedBRDF:
    """Read a Cornell ``.brdf`` file as an isotropic :class:`TabulatedBRDF` (linear sRGB).

    Parameters
    ----------
    path : the file.
    shape : grid resolution (θh, θd, φd) of the resampled table.
    method : scattered interpolation, ``"linear"`` or ``"nearest"``
        (:meth:`TabulatedBRDF.from_samples`).
    interpolation : lookup mode of the table.

    References
    ----------
    .. [1] M. Pharr, G. Humphreys, *Physically Based Rendering*, 2nd ed., §8.6.
    """
    samples = read_cornell_samples(path)
    return TabulatedBRDF.from_samples(samples, shape, method=method, interpolation=interpolation)


__all__ = ["read_cornell", "read_cornell_samples"]
