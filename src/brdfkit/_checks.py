"""Argument checks shared across brdfkit: numeric arrays, bounded counts, memory.

Every check raises a type of :mod:`brdfkit.errors`: :class:`~brdfkit.errors.ParameterError`
for an argument outside its domain, :class:`~brdfkit.errors.ResourceError` for a size above its
documented maximum or a computation that would not fit in the memory available.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from brdfkit.errors import ParameterError, ResourceError

_GIB = 2.0**30


def as_float_array(name: str, value: Any, *, finite: bool = True) -> np.ndarray:
    """``value`` as a float64 array; ``finite`` also refuses NaN and infinity.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``value`` is not numeric (a string, an object, a ragged list) or, with ``finite``,
        holds NaN or infinity; the message names ``name``.
    """
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ParameterError(f"{name} must be numeric; got {value!r:.80}") from error
    if finite and not np.all(np.isfinite(array)):
        bad = array[~np.isfinite(array)].ravel()[0]
        raise ParameterError(f"{name} must be finite; got a value of {bad}")
    return array


def check_count(name: str, value: Any, maximum: int, *, minimum: int = 1) -> int:
    """An integer argument in ``[minimum, maximum]``.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``value`` is not an integer or is below ``minimum``.
    brdfkit.errors.ResourceError
        ``value`` exceeds its documented ``maximum``.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ParameterError(f"{name} must be an integer >= {minimum}; got {value!r}")
    if value < minimum:
        raise ParameterError(f"{name} must be an integer >= {minimum}; got {value}")
    if value > maximum:
        raise ResourceError(f"{name} must be at most {maximum}; got {value}")
    return int(value)


def check_image_shape(shape: Any, maximum: int) -> tuple[int, int]:
    """An image shape ``(H, W)`` of positive integers with at most ``maximum`` pixels.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``shape`` is not two positive integers.
    brdfkit.errors.ResourceError
        It has more than ``maximum`` pixels.
    """
    if not isinstance(shape, tuple | list) or len(shape) != 2:
        raise ParameterError(f"shape must be (H, W); got {shape!r}")
    height, width = (check_count(f"shape[{k}]", n, maximum) for k, n in enumerate(shape))
    if height * width > maximum:
        raise ResourceError(f"shape {tuple(shape)} has more than {maximum} pixels")
    return height, width


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (``MemAvailable`` on Linux), or ``None``."""
    try:
        with open("/proc/meminfo") as stream:
            for line in stream:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None


def check_memory(what: str, nbytes: float) -> None:
    """Refuse a computation whose estimated peak ``nbytes`` exceeds the memory available.

    Raises
    ------
    brdfkit.errors.ResourceError
        Naming ``what``, the estimate and what is available.
    """
    available = available_memory()
    if available is not None and nbytes > available:
        raise ResourceError(
            f"{what} would need about {nbytes / _GIB:.1f} GiB of memory; "
            f"{available / _GIB:.1f} GiB is available"
        )
