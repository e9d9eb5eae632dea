"""Measured BRDFs: MERL, RGL (EPFL) and Cornell files, and tabulated BRDFs.

Every reader returns a :class:`~brdfkit.brdf.base.BRDF` (``eval``, ``pdf``, ``sample``,
``albedo``), so checks, rendering, plots and fitting (:mod:`brdfkit.fit.analytic`) work on measured
data unchanged. Measured BRDFs are data, not spec models: they are not registered with the spec
parser. They sample the cosine-weighted hemisphere (no analytic sampler exists for a table).
Every reader either returns a BRDF whose ``eval`` is finite and non-negative or raises
:class:`~brdfkit.errors.FormatError` naming the file (and the field, byte or line).

- :func:`read_merl` / :func:`write_merl` — MERL ``.binary`` (Matusik et al. 2003), bit-exact.
- :func:`read_rgl` — RGL ``.bsdf`` tensor files (Dupuy & Jakob 2018), evaluated as Mitsuba 3's
  ``measured`` plugin does; :func:`write_rgl` tabulates any BRDF as one.
- :func:`read_cornell` — Cornell ``.brdf`` spectral samples, converted to linear sRGB.
- :func:`read` — any of the three, chosen by the file's extension.
- :class:`TabulatedBRDF` — a regular half/difference grid (isotropic 3-D or anisotropic 4-D),
  from any BRDF or from scattered samples (:class:`MeasuredSamples`).
"""

import os
from pathlib import Path

from brdfkit.errors import FormatError
from brdfkit.measured._tabulated_kernels import TableKernels, table_kernels
from brdfkit.measured.cornell import read_cornell, read_cornell_samples
from brdfkit.measured.merl import MERL_SCALE, MERL_SHAPE, merl_values, read_merl, write_merl
from brdfkit.measured.rgl import RGLBRDF, read_rgl, read_tensor_file
from brdfkit.measured.rgl_writer import write_rgl, write_tensor_file
from brdfkit.measured.tabulated import (
    INTERPOLATIONS,
    CosineSampled,
    MeasuredSamples,
    TabulatedBRDF,
    lookup,
    spectrum_to_rgb_matrix,
)

READERS = {".binary": read_merl, ".bsdf": read_rgl, ".brdf": read_cornell}
"""The reader of each measured-BRDF file extension."""


def read(path: str | os.PathLike) -> TabulatedBRDF | RGLBRDF:
    """Read a MERL ``.binary``, RGL ``.bsdf`` or Cornell ``.brdf`` file by its extension.

    Raises
    ------
    FormatError
        For another extension (listing the known ones), or as the reader raises.

    Examples
    --------
    >>> read("photo.png")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.FormatError: photo.png: must end in one of .binary, .bsdf, .brdf to be read ...

    A file the reader cannot make sense of is named with the field and byte that are wrong:

    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "short.binary"
    ...     _ = path.write_bytes(b"1234")
    ...     read(path)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.FormatError: .../short.binary (field 'dimensions', byte 0): truncated: ...
    """
    suffix = Path(path).suffix.lower()
    if suffix not in READERS:
        raise FormatError(
            path, f"must end in one of {', '.join(READERS)} to be read as a measured BRDF"
        )
    return READERS[suffix](path)


__all__ = [
    "INTERPOLATIONS",
    "MERL_SCALE",
    "MERL_SHAPE",
    "READERS",
    "RGLBRDF",
    "CosineSampled",
    "MeasuredSamples",
    "TableKernels",
    "TabulatedBRDF",
    "lookup",
    "merl_values",
    "read",
    "read_cornell",
    "read_cornell_samples",
    "read_merl",
    "read_rgl",
    "read_tensor_file",
    "spectrum_to_rgb_matrix",
    "table_kernels",
    "write_merl",
    "write_rgl",
    "write_tensor_file",
]
