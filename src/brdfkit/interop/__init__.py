"""Interoperability with the tools of the field.

:mod:`~brdfkit.interop.mitsuba`: Mitsuba 3 scenes that see exactly what brdfkit's sphere
renders see (the oracle of the rendering tests and the peer of the benchmarks).
:mod:`~brdfkit.interop.mitsuba_export`: brdfkit models as Mitsuba 3 BSDFs (dict and XML).
:mod:`~brdfkit.interop.export`: one entry point that writes any export format.
"""

from brdfkit.interop.export import FORMATS, Exported, check_format, export
from brdfkit.interop.mitsuba_export import (
    mitsuba_approximations,
    to_mitsuba_dict,
    to_mitsuba_xml,
    write_mitsuba_xml,
)

__all__ = [
    "FORMATS",
    "Exported",
    "check_format",
    "export",
    "mitsuba_approximations",
    "to_mitsuba_dict",
    "to_mitsuba_xml",
    "write_mitsuba_xml",
]
