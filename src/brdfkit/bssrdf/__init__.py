"""Subsurface scattering: media, an exact reference and the BSSRDF's diffusion models.

- :mod:`~brdfkit.bssrdf.medium`: a homogeneous medium (albedo, extinction, Henyey–Greenstein
  phase function, boundary index);
- :mod:`~brdfkit.bssrdf.random_walk`: the reference, a Monte Carlo random walk below a smooth
  dielectric boundary (reflectance, its standard error, the radial profile);
- :mod:`~brdfkit.bssrdf.chandrasekhar`: the exact reflectance of an isotropically scattering
  half-space, the random walk's oracle;
- :mod:`~brdfkit.bssrdf.diffusion` and :mod:`~brdfkit.bssrdf.normalized_diffusion`: the
  classical and better dipoles, photon beam diffusion and Christensen–Burley's normalized
  diffusion as radial profiles, with their albedo inversion;
- :mod:`~brdfkit.bssrdf.profile_sampling`: sampling of radii and of exit points by axis
  projection;
- :mod:`~brdfkit.bssrdf.sphere`: a BSSRDF sphere beside the BRDF sphere of the same albedo,
  and a diffusion model's translucent sphere under an environment;
- :mod:`~brdfkit.bssrdf.sphere_walk`: the reference render of that sphere, volumetric path
  tracing (what Mitsuba 3's ``volpath`` computes).
"""

from brdfkit.bssrdf.chandrasekhar import chandrasekhar_reflectance, h_function
from brdfkit.bssrdf.diffusion import (
    BetterDipole,
    ClassicalDipole,
    DiffusionProfile,
    PhotonBeamDiffusion,
    fresnel_moment,
    invert_albedo,
)
from brdfkit.bssrdf.medium import Medium, henyey_greenstein, sample_henyey_greenstein
from brdfkit.bssrdf.normalized_diffusion import NormalizedDiffusion
from brdfkit.bssrdf.profile_sampling import Probe, RadialSampler
from brdfkit.bssrdf.random_walk import (
    RadialProfile,
    WalkTally,
    random_walk_profile,
    random_walk_reflectance,
    tally_walks,
)
from brdfkit.bssrdf.sphere import diffusion_sphere, subsurface_spheres
from brdfkit.bssrdf.sphere_walk import random_walk_sphere

__all__ = [
    "BetterDipole",
    "ClassicalDipole",
    "DiffusionProfile",
    "Medium",
    "NormalizedDiffusion",
    "PhotonBeamDiffusion",
    "Probe",
    "RadialProfile",
    "RadialSampler",
    "WalkTally",
    "chandrasekhar_reflectance",
    "diffusion_sphere",
    "fresnel_moment",
    "h_function",
    "henyey_greenstein",
    "invert_albedo",
    "random_walk_profile",
    "random_walk_reflectance",
    "random_walk_sphere",
    "sample_henyey_greenstein",
    "subsurface_spheres",
    "tally_walks",
]
