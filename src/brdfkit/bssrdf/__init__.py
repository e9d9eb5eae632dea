"""Subsurface scattering: media, an exact reference and the BSSRDF's diffusion models.

- :mod:`~brdfkit.bssrdf.medium`: a homogeneous medium (albedo, extinction, Henyey–Greenstein
  phase function, boundary index);
- :mod:`~brdfkit.bssrdf.random_walk`: the reference, a Monte Carlo random walk below a smooth
  dielectric boundary (reflectance, its standard error, the radial profile);
- :mod:`~brdfkit.bssrdf.chandrasekhar`: the exact reflectance of an isotropically scattering
  half-space, the random walk's oracle.
"""

from brdfkit.bssrdf.chandrasekhar import chandrasekhar_reflectance, h_function
from brdfkit.bssrdf.medium import Medium, henyey_greenstein, sample_henyey_greenstein
from brdfkit.bssrdf.random_walk import (
    RadialProfile,
    WalkTally,
    random_walk,
    random_walk_profile,
    random_walk_reflectance,
)

__all__ = [
    "Medium",
    "RadialProfile",
    "WalkTally",
    "chandrasekhar_reflectance",
    "h_function",
    "henyey_greenstein",
    "random_walk",
    "random_walk_profile",
    "random_walk_reflectance",
    "sample_henyey_greenstein",
]
