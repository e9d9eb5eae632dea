r"""MERL BRDF database files (``.binary``): read and write, bit for bit.

The published format (Matusik et al. 2003, ``BRDFRead.cpp``): three little-endian int32
dimensions ``(90, 90, 180)`` — θh, θd, φd — then :math:`3\cdot 90\cdot 90\cdot 180` float64
values, channel-major (all red, then all green, then all blue), each channel a C-order array
``[θh][θd][φd]``. Indices: θh non-linearly, :math:`i = \lfloor\sqrt{\theta_h/(\pi/2)}\cdot 90
\rfloor`; θd linearly, :math:`j = \lfloor\theta_d/(\pi/2)\cdot 90\rfloor`; φd folded into
:math:`[0, \pi)` by adding π when negative (reciprocity), :math:`k = \lfloor\varphi_d/\pi\cdot
180\rfloor`. Stored values are scaled by 1/1500, 1.15/1500 and 1.66/1500 for R, G, B. Negative
values mean "not measured" (below the horizon); they read as 0 and :func:`read_merl` counts
them (``clamped``).

A MERL file is a :class:`~brdfkit.measured.tabulated.TabulatedBRDF` of shape
``(90, 90, 180, 3)`` with those scales; the raw doubles are kept, so :func:`write_merl` of a
:func:`read_merl` result reproduces the file byte for byte.

References
----------
.. [1] W. Matusik, H. Pfister, M. Brand, L. McMillan, "A data-driven reflectance model",
       ACM TOG 22(3) (SIGGRAPH), 759–769, 2003; MERL BRDF database and ``BRDFRead.cpp``.
.. [2] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation",
       EGWR 1998.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.errors import FormatError, ParameterError
from brdfkit.io import atomic_write
from brdfkit.measured.tabulated import TabulatedBRDF

MERL_SHAPE = (90, 90, 180)
"""Resolution (θh, θd, φd) of every MERL file."""

MERL_SCALE = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
"""Per-channel factors from stored values to BRDF values (sr⁻¹), as in ``BRDFRead.cpp``."""

MERL_MAX_VALUE = 1e15
"""Largest stored value :func:`read_merl` accepts. A mirror that sends all light into the
table's smallest half-vector bin (θh below (π/2)/90², 1.9·10⁻⁴ rad) has f_r of the order of
10⁶ sr⁻¹ at normal incidence and 10⁸ near grazing, 10⁹–10¹¹ stored; a larger value is a
corrupt entry, whose square summed over the table would overflow a fit's residuals."""

_HEADER = np.dtype("<i4")
_VALUE = np.dtype("<f8")
_HEADER_BYTES = 3 * _HEADER.itemsize
_FILE_BYTES = _HEADER_BYTES + 3 * math.prod(MERL_SHAPE) * _VALUE.itemsize


def read_merl(path: str | os.PathLike, interpolation: str = "bin") -> TabulatedBRDF:
    """Read a MERL ``.binary`` file as a :class:`TabulatedBRDF` of shape ``(90, 90, 180, 3)``.

    Negative values are MERL's "not measured" marker (−1): they are kept as stored (so
    :func:`write_merl` reproduces the file) and evaluate as 0; the result's ``clamped`` says how
    many there are (0 when none), for a caller to report.

    Parameters
    ----------
    path : the file.
    interpolation : lookup mode, ``"bin"`` (default: exactly ``BRDFRead.cpp``), ``"nearest"``
        or ``"linear"``.

    Returns
    -------
    TabulatedBRDF
        The table, with ``clamped`` the number of negative values in the file.

    Raises
    ------
    FormatError
        Naming the file, when the header is not ``(90, 90, 180)``, the file is truncated or
        longer than the header says, or a value is NaN, infinite or beyond
        :data:`MERL_MAX_VALUE` (with its byte offset and table entry).

    References
    ----------
    .. [1] W. Matusik et al., SIGGRAPH 2003; ``BRDFRead.cpp``.

    Examples
    --------
    A file whose header is not MERL's:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "small.binary"
    ...     _ = path.write_bytes(np.array([2, 2, 2], dtype="<i4").tobytes())
    ...     read_merl(path)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.FormatError: .../small.binary (field 'dimensions', byte 0): ...
    """
    path = Path(path)
    raw = path.read_bytes()
    _check_layout(path, raw)
    data = np.frombuffer(raw, _VALUE, offset=_HEADER_BYTES)
    bad = np.flatnonzero(~(np.abs(data) <= MERL_MAX_VALUE))  # NaN compares False
    if bad.size:
        value = data[bad[0]]
        reason = "is not finite" if not np.isfinite(value) else f"exceeds {MERL_MAX_VALUE:g}"
        raise FormatError(
            path,
            f"value {value} {reason} ({bad.size} such values in the file; entry "
            f"{_entry(int(bad[0]))})",
            field="values",
            offset=_HEADER_BYTES + int(bad[0]) * _VALUE.itemsize,
        )
    values = np.moveaxis(data.reshape(3, *MERL_SHAPE), 0, -1).astype(np.float64)
    return TabulatedBRDF(values, scale=MERL_SCALE, interpolation=interpolation, name=path.name)


def _entry(index: int) -> str:
    """The table entry of the ``index``-th stored value: channel and (θh, θd, φd) bins."""
    channel, *bins = np.unravel_index(index, (3, *MERL_SHAPE))
    return f"{'RGB'[channel]}[{', '.join(str(int(b)) for b in bins)}]"


def _check_layout(path: Path, raw: bytes) -> None:
    """Raise :class:`FormatError` unless ``raw`` is a MERL header ``(90, 90, 180)`` followed by
    exactly that many float64 values per channel."""
    if len(raw) < _HEADER_BYTES:
        raise FormatError(
            path,
            f"truncated: {len(raw)} bytes, shorter than its {_HEADER_BYTES}-byte header",
            field="dimensions",
            offset=0,
        )
    dims = tuple(int(d) for d in np.frombuffer(raw, _HEADER, count=3))
    if dims != MERL_SHAPE:
        raise FormatError(
            path,
            f"header dimensions {dims}; expected {MERL_SHAPE} (theta_h, theta_d, phi_d)",
            field="dimensions",
            offset=0,
        )
    if len(raw) != _FILE_BYTES:
        state = "truncated" if len(raw) < _FILE_BYTES else "longer than its header says"
        raise FormatError(
            path,
            f"{state}: {len(raw)} bytes; expected {_FILE_BYTES} ({_HEADER_BYTES}-byte header + "
            f"3 x {math.prod(MERL_SHAPE)} float64 values)",
            offset=min(len(raw), _FILE_BYTES),
        )


def merl_values(brdf: BRDF) -> np.ndarray:
    """The stored (unscaled) MERL values of ``brdf``, shape ``(90, 90, 180, 3)``.

    A :class:`TabulatedBRDF` with MERL's shape and scales gives its raw table unchanged (the
    round trip is exact); any other table or model is tabulated at the MERL nodes and divided
    by :data:`MERL_SCALE`. "Not measured" entries (negative) are written as −1.
    """
    if not isinstance(brdf, BRDF):
        raise ValueError(f"brdf must be a BRDF; got {type(brdf).__name__}")
    if brdf.channels not in (1, 3):
        raise ValueError(f"a MERL file holds 1 or 3 channels; brdf has {brdf.channels}")
    if not (isinstance(brdf, TabulatedBRDF) and brdf.shape == MERL_SHAPE):
        brdf = TabulatedBRDF.from_brdf(brdf, MERL_SHAPE, channels=3)
    scale = np.broadcast_to(np.asarray(brdf.scale, dtype=np.float64), (3,))
    values = np.broadcast_to(brdf.values, (*MERL_SHAPE, 3))
    if np.array_equal(scale, MERL_SCALE):
        return values
    return np.where(values < 0, -1.0, values * (scale / np.asarray(MERL_SCALE)))


def write_merl(path: str | os.PathLike, brdf: BRDF) -> Path:
    """Write ``brdf`` as a MERL ``.binary`` file, atomically; returns the path.

    ``brdf`` is a table read by :func:`read_merl` (written back bit for bit) or any BRDF
    (tabulated at the MERL nodes first, see :func:`merl_values`).

    Raises
    ------
    brdfkit.errors.ParameterError
        ``brdf`` has NaN, infinite or larger values than :data:`MERL_MAX_VALUE` (stored).

    References
    ----------
    .. [1] W. Matusik et al., SIGGRAPH 2003; ``BRDFRead.cpp``.
    """
    path = Path(path)
    values = merl_values(brdf)
    if not np.all(np.abs(values) <= MERL_MAX_VALUE):  # NaN compares False
        raise ParameterError(
            f"brdf has values that are not finite or exceed MERL_MAX_VALUE = {MERL_MAX_VALUE:g} "
            f"(stored); {path.name} would not be read back"
        )
    header = np.asarray(MERL_SHAPE, dtype=_HEADER).tobytes()
    body = np.ascontiguousarray(np.moveaxis(values, -1, 0), dtype=_VALUE).tobytes()
    atomic_write(path, lambda tmp: tmp.write_bytes(header + body))
    return path


__all__ = ["MERL_MAX_VALUE", "MERL_SCALE", "MERL_SHAPE", "merl_values", "read_merl", "write_merl"]
