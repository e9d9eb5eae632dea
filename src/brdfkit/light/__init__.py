"""Light: the sources that illuminate a surface.

Directional and point lights, sphere, disk and rectangle area lights, a uniform sky
(:mod:`~brdfkit.light.analytic`), environment maps (:mod:`~brdfkit.light.environment`), the
Hosek–Wilkie sun and sky (:mod:`~brdfkit.light.sunsky`), and real spherical harmonics for
distant lighting (:mod:`~brdfkit.light.spherical_harmonics`). Every light follows the protocol
of :mod:`~brdfkit.light.base`; :func:`parse_light` reads the command line's light specs.
"""

from brdfkit.light.analytic import (
    DirectionalLight,
    DiskLight,
    PointLight,
    RectangleLight,
    SphereLight,
    UniformSky,
)
from brdfkit.light.base import (
    Light,
    LightSample,
)
from brdfkit.light.environment import (
    EnvironmentMap,
)
from brdfkit.light.spec import (
    parse_light,
)
from brdfkit.light.sunsky import (
    SunSky,
)

__all__ = [
    "DirectionalLight",
    "DiskLight",
    "EnvironmentMap",
    "Light",
    "LightSample",
    "PointLight",
    "RectangleLight",
    "SphereLight",
    "SunSky",
    "UniformSky",
    "parse_light",
]
