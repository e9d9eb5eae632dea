r"""Cornell gonioreflectometer files (``.brdf``, as shipped with pbrt-v2).

Text format: ``#`` comment lines; the number of wavelengths n; n wavelengths in nm; then one
row per measurement, :math:`\theta_i\ \varphi_i\ \theta_s\ \varphi_s` (radians; i the light,
s the scattered/viewing direction) followed by n spectral BRDF values (sr⁻¹). The spectra
are converted to linear sRGB through the CIE 1931 2° observer under D65
(:func:`~brdfkit.measured.tabulated.spectrum_to_rgb_matrix`, colour-science's integration);
saturated colours outside the sRGB gamut (a negative channel) are clipped to 0 in that channel.

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

from brdfkit.errors import FormatError
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.measured.tabulated import (
    MIN_SAMPLES,
    MeasuredSamples,
    TabulatedBRDF,
    spectrum_to_rgb_matrix,
    wavelengths_problem,
)


def read_cornell_samples(path: str | os.PathLike) -> MeasuredSamples:
    """The measurements of a Cornell ``.brdf`` file, as linear-sRGB :class:`MeasuredSamples`.

    ``wi`` comes from (θi, φi), ``wo`` from (θs, φs); ``spectral`` and ``wavelengths`` keep the
    original spectra. As in pbrt, the numbers after the comments are one stream: rows may wrap
    over lines.

    Raises
    ------
    FormatError
        Naming the file and the line, when it is not UTF-8 text, holds a non-number, a NaN, an
        infinity or a negative spectral value, a bad wavelength count or wavelengths
        (:func:`~brdfkit.measured.tabulated.wavelengths_problem`), rows that are not 4 angles +
        n values, or values too large to convert to sRGB.

    References
    ----------
    .. [1] M. Pharr, G. Humphreys, *Physically Based Rendering*, 2nd ed., §8.6.
    """
    path = Path(path)
    numbers, lines = _numbers(path)
    n = _wavelength_count(path, numbers, lines)
    wavelengths, rows = numbers[1 : 1 + n], numbers[1 + n :]
    width = 4 + n
    if wavelengths.size != n or rows.size == 0 or rows.size % width:
        raise FormatError(
            path,
            f"after {n} wavelengths expected rows of 4 angles + {n} values; got "
            f"{wavelengths.size + rows.size} numbers after the count",
            offset=_misaligned_line(lines, n, width),
            line=True,
        )
    problem = wavelengths_problem(wavelengths)
    if problem:
        raise FormatError(path, problem, field="wavelengths", offset=int(lines[1]), line=True)
    rows, row_lines = rows.reshape(-1, width), lines[1 + n :].reshape(-1, width)
    spectral = rows[:, 4:]
    negative = np.argwhere(spectral < 0)
    if negative.size:
        i, j = negative[0]
        raise FormatError(
            path,
            f"spectral value {spectral[i, j]} is negative (a BRDF is not)",
            offset=int(row_lines[i, 4 + j]),
            line=True,
        )
    # Saturated spectra fall outside the sRGB gamut (a negative channel); clip them to it.
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is checked right below
        rgb = np.maximum(spectral @ spectrum_to_rgb_matrix(wavelengths), 0.0)
    overflow = np.flatnonzero(~np.all(np.isfinite(rgb), axis=-1))
    if overflow.size:
        raise FormatError(
            path,
            "spectral values too large to convert to sRGB (the sum overflows)",
            offset=int(row_lines[overflow[0], 0]),
            line=True,
        )
    wi = spherical_to_cartesian(rows[:, 0], rows[:, 1])
    wo = spherical_to_cartesian(rows[:, 2], rows[:, 3])
    return MeasuredSamples(wi, wo, rgb, spectral, wavelengths, name=path.name)


def _numbers(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The file's numbers (comments removed) and the 1-based line each stands on.

    Raises
    ------
    FormatError
        For bytes that are not UTF-8, a word that is not a number, or a NaN or infinity.
    """
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw[: error.start].count(b"\n") + 1
        raise FormatError(path, f"not UTF-8 text: {error.reason}", offset=line, line=True) from None
    words, lines = [], []
    for number, line in enumerate(text.split("\n"), start=1):
        found = line.split("#", 1)[0].split()
        words += found
        lines += [number] * len(found)
    lines = np.asarray(lines, dtype=np.int64)
    try:
        numbers = np.array(words, dtype=np.float64)
    except ValueError:
        bad = next(k for k, word in enumerate(words) if not _is_number(word))
        raise FormatError(
            path, f"holds a non-number, {words[bad]!r}", offset=int(lines[bad]), line=True
        ) from None
    non_finite = np.flatnonzero(~np.isfinite(numbers))
    if non_finite.size:
        bad = non_finite[0]
        raise FormatError(
            path, f"{words[bad]!r} is not a finite number", offset=int(lines[bad]), line=True
        )
    return numbers, lines


def _is_number(word: str) -> bool:
    """Whether NumPy reads ``word`` as a float64."""
    try:
        np.float64(word)
    except ValueError:
        return False
    return True


def _wavelength_count(path: Path, numbers: np.ndarray, lines: np.ndarray) -> int:
    """The leading wavelength count, checked to be a whole number >= 1."""
    if numbers.size == 0 or numbers[0] != np.round(numbers[0]) or numbers[0] < 1:
        first = numbers[0] if numbers.size else "no number"
        raise FormatError(
            path,
            f"must start with the wavelength count (a whole number >= 1); got {first}",
            field="wavelength count",
            offset=int(lines[0]) if numbers.size else None,
            line=True,
        )
    return int(numbers[0])


def _misaligned_line(lines: np.ndarray, n: int, width: int) -> int:
    """The line where the rows go wrong, given the line of each number (the count, ``n``
    wavelengths, then rows of ``width``): the first row that starts mid-line or spans lines,
    else the last, incomplete row; the last line when the wavelengths run out."""
    if lines.size <= 1 + n:
        return int(lines[-1])
    starts = np.arange(1 + n, lines.size, width)
    ends = np.minimum(starts + width, lines.size) - 1
    wrong = np.flatnonzero((lines[starts] == lines[starts - 1]) | (lines[starts] != lines[ends]))
    return int(lines[starts[wrong[0]] if wrong.size else starts[-1]])


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

    Raises
    ------
    FormatError
        As :func:`read_cornell_samples`, or when fewer than
        :data:`~brdfkit.measured.tabulated.MIN_SAMPLES` rows have both directions above the
        surface.

    References
    ----------
    .. [1] M. Pharr, G. Humphreys, *Physically Based Rendering*, 2nd ed., §8.6.
    """
    samples = read_cornell_samples(path)
    usable = int(np.count_nonzero(samples.valid))
    if usable < MIN_SAMPLES:
        raise FormatError(
            path,
            f"{usable} rows have both directions above the surface; at least {MIN_SAMPLES} are "
            "needed to tabulate the BRDF",
        )
    return TabulatedBRDF.from_samples(samples, shape, method=method, interpolation=interpolation)


__all__ = ["read_cornell", "read_cornell_samples"]
