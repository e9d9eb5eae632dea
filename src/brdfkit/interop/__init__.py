"""Interoperability with the tools of the field.

:mod:`~brdfkit.interop.mitsuba`: Mitsuba 3 scenes that see exactly what brdfkit's sphere
renders see (the oracle of the rendering tests and the peer of the benchmarks).
:mod:`~brdfkit.interop.load`: :func:`brdfkit.load`, a BRDF from any source (BRDF Explorer too).
"""

__all__ = []
